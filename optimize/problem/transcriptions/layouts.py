"""Direct Radau collocation of the cycle OCP into one scaled NLP, in two layouts.

The collocation's NLP (:class:`optimize.problem.transcriptions.collocation.CollocationMethod`
runs it; the condensed transcription is built beside the general layout).

Takes a formulation (what is optimized: any
:class:`optimize.problem.interface.CycleFormulation`; the kite's is
:class:`optimize.problem.formulation.Formulation`) and a
:class:`optimize.problem.options.Discretization` (how finely) and lays out
the decision vector ``w``, the constraint vector ``g`` and the parameters ``p``.
Each decision variable is stored divided by its typical magnitude. Both layouts
give the same NLP (same variables up to copies, same rows up to the rows that tie
the copies), so they have the same optima. Every size comes from the formulation's
model (``form.dae``), the scalar parameters from their names
(:func:`optimize.problem.interface.param_names`):

* :func:`general_layout` (``Layout.name`` ``"general"``), for a general sparse solver.
  Decision vector, in this order: one copy of the period ``T`` per interval (tied
  by equality rows, so no variable couples every interval); states at the
  ``N d + 1`` grid points (interval starts and the Radau points; the last Radau
  point of an interval is the start of the next); algebraic variables at the
  ``N d`` Radau points; one control per interval; fictitious forces/moments at
  the ``N d`` Radau points (homotopy only; fixed at zero otherwise). Constraint
  vector: per Radau point the collocation rows of the dynamics then the
  formulation's point rows; then the period ties, the start rows, the
  periodicity rows and the rows on cycle averages.
* :func:`stagewise_layout` (``"stagewise"``), for a Riccati-based solver
  (fatrop): the variables and rows of each interval form one stage, and stages
  couple only through ``x_{k+1} - F(x_k, u_k) = 0``. The stage state carries,
  besides the model state at the interval start, the period and the cycle's start
  state (constant along the horizon) and the running integrals of the constrained
  cycle averages (the squared torque of an RMS-torque rating), so that periodicity
  and the rows on averages are constraints of the last stage.

:attr:`Layout.rows` finds rows by name in either layout. In both, every Radau point's
rows and integrands come from one :class:`PointFunction`, and each layout records
where its points sit (:class:`PointBlocks`), so the derivatives are built once per
point function rather than over the whole NLP.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.collocation import Collocation
from optimize.problem.interface import CycleFormulation, Row, param_names
from optimize.problem.options import Discretization
from optimize.problem.transcriptions.structure import (
    Layout,
    PointBlocks,
    PointFunction,
    Transcription,
    Vector,
    dims,
    named_variables,
)


class _Rows:
    """Collects :class:`Row` objects into ``g`` with both sets of bounds."""

    def __init__(self) -> None:
        self.exprs: list = []
        self.lo: list[float] = []
        self.hi: list[float] = []
        self.lo_lim: list[float] = []
        self.hi_lim: list[float] = []
        self.index: dict[str, list[int]] = {}
        self.n = 0

    def add(self, row: Row) -> None:
        size = row.expr.shape[0]
        lim = row.limited if row.limited is not None else (row.lo, row.hi)
        self.exprs.append(row.expr)
        for out, value in ((self.lo, row.lo), (self.hi, row.hi), (self.lo_lim, lim[0]),
                           (self.hi_lim, lim[1])):
            out.extend([float(value)] * size)
        self.index.setdefault(row.name, []).extend(range(self.n, self.n + size))
        self.n += size

    def merge(self, other: _Rows) -> None:
        """Append the rows of ``other`` (in their order)."""
        for name, idx in other.index.items():
            self.index.setdefault(name, []).extend(i + self.n for i in idx)
        self.exprs += other.exprs
        self.lo += other.lo
        self.hi += other.hi
        self.lo_lim += other.lo_lim
        self.hi_lim += other.hi_lim
        self.n += other.n


@dataclass
class _Sums:
    """Running cycle averages and penalty sums of a transcription (symbolic)."""

    averages: dict[str, Any]
    fict: Any = 0
    reg: Any = 0
    track: Any = 0

    @classmethod
    def of(cls, form: CycleFormulation) -> _Sums:
        """Zero sums of the cycle averages of ``form``."""
        return cls(averages=dict.fromkeys(form.averages, 0))


def point_function(form: CycleFormulation, coll: Collocation, n_intervals: int,
                   scale_w: dict[str, np.ndarray]) -> PointFunction:
    """Build the :class:`PointFunction` of ``form`` on ``n_intervals`` intervals.

    ``scale_w`` has the scale of each part of ``v`` (``period, x, u, z, f``).
    """
    d, nx = coll.degree, form.dae.states.size
    sizes = {"period": 1, "x": nx, "u": form.dae.controls.size, "z": form.dae.algebraic.size,
             "f": form.dae.fictitious.size}
    v = ca.SX.sym("v", sum(sizes.values()) + (d + 1) * nx)
    parts, start = {}, 0
    for name, size in sizes.items():
        parts[name] = v[start:start + size] * ca.DM(scale_w[name])
        start += size
    xs = [v[start + r * nx: start + (r + 1) * nx] * ca.DM(scale_w["x"])
          for r in range(d + 1)]
    params = ca.SX.sym("params", len(form.parameters))
    deriv = ca.SX.sym("deriv", d + 1)
    x, u, z = parts["x"], parts["u"], parts["z"]
    xp = sum(deriv[r] * xs[r] for r in range(d + 1))
    h = parts["period"] / n_intervals
    dynamics = Row("dynamics", (xp - h * form.ode(x, u, z)) * ca.DM(1.0 / form.scales.state))
    point = form.point(x, u, z, parts["f"], params)
    templates = (dynamics, *point.rows)
    integrands = ca.vertcat(*[point.averages[a] for a in form.averages], point.fict_sq)
    function = ca.Function("radau_point", [v, params, deriv],
                           [ca.vertcat(*[t.expr for t in templates]), integrands],
                           ["v", "params", "deriv"], ["rows", "integrands"])
    return PointFunction(function=function, templates=templates,
                         integrands=(*form.averages, "fict_sq"))


def _point_scales(form: CycleFormulation) -> dict[str, np.ndarray]:
    sc = form.scales
    return {"period": np.array([sc.period_s]), "x": sc.state, "u": sc.control,
            "z": sc.algebraic, "f": sc.fictitious}


def _interval(point: PointFunction, coll: Collocation, w: Any, i_period: int,
              i_xs: list[np.ndarray], i_u: np.ndarray, i_zs: list[np.ndarray],
              i_fs: list[np.ndarray], params: Any, rows: _Rows
              ) -> list[tuple[np.ndarray, np.ndarray, Any]]:
    """Rows of one collocation interval of the scaled decision vector ``w``.

    ``i_xs`` are the indices of the ``d + 1`` states (interval start, then the Radau
    points), ``i_zs`` and ``i_fs`` of the ``d`` algebraic variables and fictitious
    forces. Returns per Radau point the indices of its ``v`` in ``w``, of its rows in
    ``g`` and its integrands (for the cycle sums, :func:`_add_integrands`).
    """
    out = []
    for j in range(1, coll.degree + 1):
        idx = np.concatenate([[i_period], i_xs[j], i_u, i_zs[j - 1], i_fs[j - 1], *i_xs])
        g, integrands = point.function(w[[int(i) for i in idx]], params,
                                       ca.DM(coll.deriv[:, j - 1]))
        first = rows.n
        for row in point.rows_of(g):
            rows.add(row)
        out.append((idx, np.arange(first, rows.n), integrands))
    return out


def share(coll: Collocation, n: int, j: int, value: Any) -> Any:
    """Point ``j``'s (1-based) share of a cycle average whose integrand is ``value``."""
    return coll.quad[j - 1] / n * value


def _add_integrands(sums: _Sums, coll: Collocation, n: int, j: int, s: Any) -> None:
    """Add point ``j``'s (1-based) integrands ``s`` (the cycle averages in the order of
    ``sums.averages``, then the squared fictitious forces) to ``sums``."""
    for i, name in enumerate(sums.averages):
        sums.averages[name] += share(coll, n, j, s[i])
    sums.fict += s[len(sums.averages)] / (n * coll.degree)


def _params(form: CycleFormulation, n_points: int
            ) -> tuple[ca.SX, dict, int, np.ndarray, dict[str, int]]:
    """Parameter vector: the scalar parameters by name
    (:func:`optimize.problem.interface.param_names`), then the tracking reference per
    grid point."""
    names, nx = param_names(form), form.dae.states.size
    n_par = len(names)
    n_p = n_par + nx * n_points
    p = ca.SX.sym("p", n_p)
    par = {name: p[i] for i, name in enumerate(names)}
    i_p_ref = n_par + np.arange(nx * n_points).reshape(n_points, nx).T
    return p, par, n_p, i_p_ref, {name: i for i, name in enumerate(names)}


def model_params(form: CycleFormulation, par: dict[str, Any]) -> Any:
    """The model's parameters (``form.parameters``) as one vector of the NLP's ``p``."""
    return ca.vertcat(*[par[name] for name in form.parameters])


def _param_indices(form: CycleFormulation, i_par: dict[str, int]) -> list[int]:
    """Indices in ``p`` of the model's parameters (``form.parameters``)."""
    return [i_par[name] for name in form.parameters]


def _tracking(form: CycleFormulation, p: ca.SX, i_p_ref: np.ndarray, xs: list) -> Any:
    """Mean squared scaled deviation of the grid-point states from the reference."""
    inv_sx = ca.DM(1.0 / form.scales.state)
    return sum(ca.sumsqr(x * inv_sx - p[[int(i) for i in i_p_ref[:, k]]])
               for k, x in enumerate(xs)) / len(xs)


def _variable_bounds(form: CycleFormulation, n_w: int, i_period: np.ndarray, i_x: np.ndarray,
                     i_z: np.ndarray, i_u: np.ndarray) -> tuple[np.ndarray, ...]:
    """Physical ``lbw, ubw`` without and with the drive limits."""
    lbw, ubw = np.full(n_w, -np.inf), np.full(n_w, np.inf)
    lbw[i_period], ubw[i_period] = form.period_bounds()
    x_lo, x_hi = form.state_bounds()
    lbw[i_x], ubw[i_x] = x_lo[:, None], x_hi[:, None]
    for i, value in form.start_state_fixed().items():
        lbw[i_x[i, 0]] = ubw[i_x[i, 0]] = value
    z_lo, z_hi = form.algebraic_bounds()
    lbw[i_z], ubw[i_z] = z_lo[:, None], z_hi[:, None]
    u_lo, u_hi = form.control_bounds()
    lbw[i_u], ubw[i_u] = u_lo[:, None], u_hi[:, None]
    lbw_lim, ubw_lim = lbw.copy(), ubw.copy()
    for i, (lo, hi) in form.limited_state_bounds().items():
        lbw_lim[i_x[i]], ubw_lim[i_x[i]] = lo, hi
    return lbw, ubw, lbw_lim, ubw_lim


def _scale_w(form: CycleFormulation, n_w: int, i_period: np.ndarray, i_x: np.ndarray,
             i_z: np.ndarray, i_u: np.ndarray, i_f: np.ndarray) -> np.ndarray:
    sc = form.scales
    scale_w = np.ones(n_w)
    scale_w[i_period] = sc.period_s
    scale_w[i_x] = sc.state[:, None]
    scale_w[i_z] = sc.algebraic[:, None]
    scale_w[i_u] = sc.control[:, None]
    scale_w[i_f] = sc.fictitious[:, None]
    return scale_w


def _finish(nlp: dict, blocks: PointBlocks, layout: Layout, rows: _Rows,
            bounds: tuple[np.ndarray, ...]) -> Transcription:
    lbw, ubw, lbw_lim, ubw_lim = (b / layout.scale_w for b in bounds)
    lbg, ubg = np.array(rows.lo), np.array(rows.hi)
    lbg_lim, ubg_lim = np.array(rows.lo_lim), np.array(rows.hi_lim)
    layout.equality = (lbg == ubg) & (lbg_lim == ubg_lim)
    return Transcription(nlp=nlp, layout=layout, lbw=lbw, ubw=ubw, lbg=lbg, ubg=ubg,
                         limited=(lbw_lim, ubw_lim, lbg_lim, ubg_lim), blocks=blocks)


def _nlp_and_blocks(w: Any, p: Any, f_s: Any, g_s: Any, s: Any, point: PointFunction,
                    points: list, deriv: np.ndarray, i_params: np.ndarray
                    ) -> tuple[dict, PointBlocks]:
    """The NLP, with the points' integrands in place of the symbols ``s``, and its
    :class:`PointBlocks` (``points`` as :func:`_interval` returns them, in the order
    of the columns of ``s``)."""
    integrands = ca.horzcat(*[pt[2] for pt in points])
    f, g = ca.substitute([f_s, g_s], [ca.vec(s)], [ca.vec(integrands)])
    blocks = PointBlocks(
        point=point, vars=np.stack([pt[0] for pt in points], axis=1),
        rows=np.stack([pt[1] for pt in points], axis=1), deriv=deriv, s=s, f_s=f_s,
        g_s=g_s, i_params=np.asarray(i_params, dtype=int))
    return {"x": w, "p": p, "f": f, "g": g}, blocks


def general_layout(form: CycleFormulation, disc: Discretization, coll: Collocation
                      ) -> Transcription:
    """Transcribe ``form`` by Radau collocation on ``disc.n_intervals`` intervals
    (the layout for a general sparse solver, see the module docstring)."""
    sc = form.scales
    n, d = disc.n_intervals, coll.degree
    nx, nz, nu, nf = dims(form)
    n_points, n_coll = n * d + 1, n * d

    vec = Vector()
    i_period = vec.take("period", n)
    i_x = vec.columns("x", nx, n_points)
    i_z = vec.columns("z", nz, n_coll)
    i_u = vec.columns("u", nu, n)
    i_f = vec.columns("f", nf, n_coll)
    n_w = vec.n
    scale_w = _scale_w(form, n_w, i_period, i_x, i_z, i_u, i_f)
    p, par, n_p, i_p_ref, i_par = _params(form, n_points)
    w = ca.SX.sym("w", n_w)
    ws = w * ca.DM(scale_w)

    def col(idx: np.ndarray, k: int) -> ca.SX:
        return ws[[int(i) for i in idx[:, k]]]

    xs = [col(i_x, k) for k in range(n_points)]
    point = point_function(form, coll, n, _point_scales(form))
    rows, sums = _Rows(), _Sums.of(form)
    # the integrands enter f and g through the symbols s (substituted below), so the
    # derivatives can be built point by point (optimize.problem.transcriptions.derivatives)
    s = ca.SX.sym("s", len(point.integrands), n_coll)
    points = []
    for k in range(n):
        sums.reg += form.control_cost(col(i_u, k)) / n
        points += _interval(point, coll, w, int(i_period[k]),
                            [i_x[:, k * d + r] for r in range(d + 1)], i_u[:, k],
                            [i_z[:, k * d + j] for j in range(d)],
                            [i_f[:, k * d + j] for j in range(d)], model_params(form, par),
                            rows)
        for j in range(1, d + 1):
            _add_integrands(sums, coll, n, j, s[:, k * d + j - 1])
    sums.track = _tracking(form, p, i_p_ref, xs)

    # one period copy per interval keeps the KKT matrix banded (no dense period column)
    rows.add(Row("period_tie", ca.vertcat(*[(ws[int(i_period[k + 1])] - ws[int(i_period[k])])
                                            / sc.period_s for k in range(n - 1)])))
    for row in (*form.start_rows(xs[0]), *form.periodicity_rows(xs[0], xs[-1]),
                *form.average_rows(sums.averages)):
        rows.add(row)

    f_s = form.objective(par, sums.averages, sums.reg, sums.track, sums.fict)
    nlp, blocks = _nlp_and_blocks(w, p, f_s, ca.vertcat(*rows.exprs), s, point, points,
                                  np.tile(coll.deriv, (1, n)), _param_indices(form, i_par))
    layout = Layout(
        n_points=n_points, n_coll=n_coll, i_period=i_period, i_x=i_x, i_z=i_z, i_u=i_u,
        i_f=i_f, scale_w=scale_w, n_w=n_w, n_g=rows.n, n_p=n_p, i_p_ref=i_p_ref,
        params=i_par, rows={name: np.array(idx, dtype=int) for name, idx in rows.index.items()},
        variables=named_variables(form, i_period, i_x, i_z, i_u, i_f),
    )
    return _finish(nlp, blocks, layout, rows,
                   _variable_bounds(form, n_w, i_period, i_x, i_z, i_u))


@dataclass(frozen=True)
class _Stages:
    """Indices into ``w`` of the stage-wise layout (:func:`stagewise_layout`)."""

    i_x: np.ndarray  # (nx, N d + 1) model states: X_0, then the Radau points
    i_z: np.ndarray  # (nz, N d)
    i_u: np.ndarray  # (nu, N)
    i_f: np.ndarray  # (nf, N d)
    i_start: np.ndarray  # (nx, N + 1) S_k, copies of the cycle's start state
    i_next: np.ndarray  # (nx, N) X_{k+1}, copies of the interval's last Radau point
    i_period: np.ndarray  # (N + 1,) T_k
    i_q: np.ndarray  # (number of carried averages, N + 1) running integrals Q_k
    n_w: int

    def x_start(self, k: int) -> np.ndarray:
        """Indices of the model state at the start of interval ``k``."""
        return self.i_x[:, 0] if k == 0 else self.i_next[:, k - 1]


def _stage_indices(n: int, d: int, dims: tuple[int, int, int, int], n_q: int) -> _Stages:
    """Lay out ``w`` stage by stage: ``x_k = (X_k, T_k, S_k, Q_k)``, then ``u_k = (U_k,
    the Radau points' states, algebraic variables and fictitious forces)``."""
    nx, nz, nu, nf = dims
    vec = Vector()
    i_x, i_z = np.zeros((nx, n * d + 1), dtype=int), np.zeros((nz, n * d), dtype=int)
    i_u, i_f = np.zeros((nu, n), dtype=int), np.zeros((nf, n * d), dtype=int)
    i_start, i_next = np.zeros((nx, n + 1), dtype=int), np.zeros((nx, n), dtype=int)
    i_period, i_q = np.zeros(n + 1, dtype=int), np.zeros((n_q, n + 1), dtype=int)
    for k in range(n + 1):
        if k == 0:
            i_x[:, 0] = vec.take("x", nx)
        else:
            i_next[:, k - 1] = vec.take("x_next", nx)
        i_period[k] = vec.take("period", 1)[0]
        i_start[:, k] = vec.take("x_start", nx)
        i_q[:, k] = vec.take("running_averages", n_q)
        if k == n:
            break
        i_u[:, k] = vec.take("u", nu)
        for j in range(d):
            i_x[:, k * d + j + 1] = vec.take("x", nx)
        for j in range(d):
            i_z[:, k * d + j] = vec.take("z", nz)
        for j in range(d):
            i_f[:, k * d + j] = vec.take("f", nf)
    return _Stages(i_x, i_z, i_u, i_f, i_start, i_next, i_period, i_q, vec.n)


def _stage_rows(form: CycleFormulation, coll: Collocation, st: _Stages, w: Any, at: Any,
                point: PointFunction, s: Any, params: Any) -> tuple[_Rows, _Sums, dict, list]:
    """Rows of stages ``0 .. N-1``: first the gap-closing rows ``x_{k+1} - F(x_k, u_k)``
    (in the order of ``x_{k+1}``), then the interval's rows; stage 0 also has the start
    rows and ``S_0 = X_0``. Returns the rows, the cycle sums, the running integrals
    (``w`` index -> value) and the points (as :func:`_interval` returns them)."""
    n, d = st.i_u.shape[1], coll.degree
    carried = [point.integrands.index(c) for c in form.constrained_averages]
    rows, sums = _Rows(), _Sums.of(form)
    running, q_running = {}, [0] * len(carried)
    all_points = []
    for k in range(n):
        interval_rows = _Rows()
        sums.reg += form.control_cost(at(st.i_u[:, k])) / n
        points = _interval(point, coll, w, int(st.i_period[k]),
                           [st.x_start(k)] + [st.i_x[:, k * d + j] for j in range(1, d + 1)],
                           st.i_u[:, k], [st.i_z[:, k * d + j] for j in range(d)],
                           [st.i_f[:, k * d + j] for j in range(d)], params, interval_rows)
        for j in range(1, d + 1):
            _add_integrands(sums, coll, n, j, s[:, k * d + j - 1])
        gap = [w[st.i_next[:, k]] - w[st.i_x[:, k * d + d]],
               w[st.i_period[k + 1]] - w[st.i_period[k]],
               w[st.i_start[:, k + 1]] - w[st.i_start[:, k]]]
        for c, i_int in enumerate(carried):
            dq = sum(share(coll, n, j, s[i_int, k * d + j - 1]) for j in range(1, d + 1))
            gap.append(w[st.i_q[c, k + 1]] - w[st.i_q[c, k]] - dq)
            q_running[c] += sum(share(coll, n, j, pt[2][i_int])
                                for j, pt in enumerate(points, start=1))
            running[int(st.i_q[c, k + 1])] = q_running[c]
        rows.add(Row("continuity", ca.vertcat(*gap)))
        if k == 0:
            for row in form.start_rows(at(st.i_x[:, 0])):
                rows.add(row)
            rows.add(Row("start_copy", w[st.i_start[:, 0]] - w[st.i_x[:, 0]]))
        all_points += [(idx, at_rows + rows.n, integ) for idx, at_rows, integ in points]
        rows.merge(interval_rows)
    return rows, sums, running, all_points


def _stage_completion(st: _Stages, w: Any, running: dict, d: int) -> ca.Function:
    """``w`` with its copies and running integrals set from the other variables."""
    derived = dict(running)
    for k in range(st.i_next.shape[1]):
        for i, src in zip(st.i_next[:, k], st.i_x[:, k * d + d], strict=True):
            derived[int(i)] = w[int(src)]
    for k in range(st.i_start.shape[1]):
        for i, src in zip(st.i_start[:, k], st.i_x[:, 0], strict=True):
            derived[int(i)] = w[int(src)]
    filled = ca.SX(w)
    for i, expr in derived.items():
        filled[i] = expr
    return ca.Function("complete", [w], [filled])


def stagewise_layout(form: CycleFormulation, disc: Discretization, coll: Collocation
                          ) -> Transcription:
    """Transcribe ``form`` by Radau collocation in stages (the layout of a Riccati-based
    solver such as fatrop, see the module docstring).

    Stage ``k < N``: state ``x_k = (X_k, T_k, S_k, Q_k)`` (model state at the interval
    start, period, the cycle's start state, running integrals of the constrained cycle
    averages, :attr:`CycleFormulation.constrained_averages`), control ``u_k = (U_k,
    X_k1..X_kd, Z_k1..Z_kd, F_k1..F_kd)`` (control, states, algebraic variables and
    fictitious forces at the Radau points). Rows of stage ``k``: first ``x_{k+1} -
    F(x_k, u_k)`` (``X_{k+1} = X_kd``, ``T``, ``S`` and ``Q`` carried), then the
    interval's rows; stage 0 also has the start rows and ``S_0 = X_0``. The last stage
    ``N`` has only a state and the periodicity (``X_N`` against ``S_N``) and average rows.
    """
    n, d = disc.n_intervals, coll.degree
    n_points, n_coll = n * d + 1, n * d
    carried = form.constrained_averages
    st = _stage_indices(n, d, dims(form), len(carried))
    scale_w = _scale_w(form, st.n_w, st.i_period, st.i_x, st.i_z, st.i_u, st.i_f)
    scale_w[st.i_start] = scale_w[st.i_x[:, :1]]
    scale_w[st.i_next] = scale_w[st.i_x[:, d::d]]
    p, par, n_p, i_p_ref, i_par = _params(form, n_points)
    w = ca.SX.sym("w", st.n_w)
    ws = w * ca.DM(scale_w)

    def at(idx: np.ndarray) -> ca.SX:
        return ws[[int(i) for i in np.atleast_1d(idx)]]

    point = point_function(form, coll, n, _point_scales(form))
    s = ca.SX.sym("s", len(point.integrands), n_coll)  # the integrands, as in general_layout
    rows, sums, running, all_points = _stage_rows(form, coll, st, w, at, point, s,
                                                  model_params(form, par))
    sums.track = _tracking(form, p, i_p_ref, [at(st.i_x[:, k]) for k in range(n_points)])
    terminal = [*form.periodicity_rows(at(st.i_start[:, n]), at(st.x_start(n)))]
    if carried:
        terminal += form.average_rows({c: w[int(st.i_q[i, n])] for i, c in enumerate(carried)})
    for row in terminal:
        rows.add(row)

    f_s = form.objective(par, sums.averages, sums.reg, sums.track, sums.fict)
    nlp, blocks = _nlp_and_blocks(w, p, f_s, ca.vertcat(*rows.exprs), s, point, all_points,
                                  np.tile(coll.deriv, (1, n)), _param_indices(form, i_par))
    layout = Layout(
        n_points=n_points, n_coll=n_coll, i_period=st.i_period, i_x=st.i_x, i_z=st.i_z,
        i_u=st.i_u, i_f=st.i_f, scale_w=scale_w, n_w=st.n_w, n_g=rows.n, n_p=n_p,
        i_p_ref=i_p_ref, params=i_par,
        rows={name: np.array(idx, dtype=int) for name, idx in rows.index.items()},
        name="stagewise", complete=_stage_completion(st, w, running, d),
        variables=named_variables(form, st.i_period, st.i_x, st.i_z, st.i_u, st.i_f),
    )
    lbw, ubw, lbw_lim, ubw_lim = _variable_bounds(form, st.n_w, st.i_period[:1], st.i_x,
                                                  st.i_z, st.i_u)
    for b in (lbw, ubw, lbw_lim, ubw_lim):
        b[st.i_q[:, 0]] = 0.0
    return _finish(nlp, blocks, layout, rows, (lbw, ubw, lbw_lim, ubw_lim))
