"""Condensed transcription: multiple shooting with the Radau collocation solved inside
each interval.

The same cycle OCP as :func:`optimize.problem.transcriptions.layouts.general_layout` (any
:class:`optimize.problem.interface.CycleFormulation`), with the states and algebraic
variables at the Radau points eliminated: each interval's collocation equations (the
dynamics rows and the formulation's point row named ``algebraic``, the DAE's algebraic
equations, as many as algebraic variables) are solved for them by Newton's method inside
the interval (a CasADi rootfinder, whose first and second derivatives come from the
implicit function theorem). The NLP's unknowns are stage by stage: the state
``x_k = (X_k, T_k, S_k, Q_k)`` (model state at the interval start, period, the cycle's
start state and the running integrals of the constrained cycle averages, all carried by
equality rows as in :func:`optimize.problem.transcriptions.layouts.stagewise_layout`) and the
control ``u_k = (U_k, F_k1..F_kd)`` (control and fictitious forces at the Radau points).
Rows of stage ``k``: ``x_{k+1} - F(x_k, u_k)``, then (stage 0) the start rows and
``S_0 = X_0``, then the interval's point rows at its Radau points and the bounds of the
eliminated variables, as rows; the last stage has the periodicity and average rows.

The full layout stays the one the rest of the code reads (:class:`Layout` of the full
transcription): :meth:`CondensedNlp.condense` turns a full decision vector into a
condensed start, :meth:`CondensedNlp.expand` a condensed solution into the full vector
(the interval's collocation solved at it), and the index maps carry bounds and row
multipliers across (:mod:`optimize.problem.transcriptions.condensed_multipliers`). The
Newton solve of an interval starts from the NLP parameters ``guess``: the increments of
the states from
the interval start and the algebraic variables of a full vector (the start's).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.collocation import Collocation
from optimize.problem.interface import CycleFormulation
from optimize.problem.transcriptions.layouts import share
from optimize.problem.transcriptions.structure import Transcription, dims

#: the point row that holds the DAE's algebraic equations (solved with the dynamics)
ALGEBRAIC_ROW = "algebraic"
#: Newton's method inside an interval: residual tolerance (scaled rows) and iteration limit
NEWTON_ABSTOL = 1e-10
NEWTON_MAX_ITER = 50
#: an interval whose collocation residual is above this after Newton's method has no
#: solution there: its outputs are NaN (an evaluation error, on which the solver
#: shortens its step), never the unconverged iterate
NEWTON_CHECK = 1e-8
#: CasADi's Newton rootfinders: ``newton`` (sparse QR) and ``fast_newton`` (dense QR, the
#: one CasADi generates C code for). A NaN inside Newton's method at a trial point is an
#: unconverged interval, said by its NaN outputs (:data:`NEWTON_CHECK`), not a warning
ROOTFINDERS = {"newton": {"abstol": NEWTON_ABSTOL, "abstolStep": 0.0,
                          "max_iter": NEWTON_MAX_ITER, "linear_solver": "qr",
                          "error_on_fail": False, "show_eval_warnings": False},
               "fast_newton": {"abstol": NEWTON_ABSTOL, "max_iter": NEWTON_MAX_ITER,
                               "error_on_fail": False, "show_eval_warnings": False}}


@dataclass(frozen=True)
class CondensedNlp:
    """The condensed NLP and its maps to and from the full layout.

    ``var_src[i]``: the full ``w`` index condensed variable ``i`` copies (``-1``: a
    copy or running integral with no bounds of its own); ``row_g``: (condensed row, full
    row) pairs of the rows both have; ``row_w``: (condensed row, full variable) pairs of
    the eliminated variables' bounds; the other rows are equalities ``= 0``. ``p`` is the
    full NLP's parameters followed by ``guess`` (:meth:`condense`).
    """

    nlp: dict
    n_w: int
    n_g: int
    n_p_full: int
    var_src: np.ndarray
    row_g: np.ndarray  # (2, n) condensed row, full row
    row_w: np.ndarray  # (2, n) condensed row, full variable
    i_period: np.ndarray  # (N + 1,) T_k
    i_state: np.ndarray  # (nx, N + 1) X_k
    i_start: np.ndarray  # (nx, N + 1) S_k
    i_run: np.ndarray  # (n_q, N + 1) Q_k, the running integrals
    gap_rows: np.ndarray  # rows x_{k+1} - F(x_k, u_k) and S_0 - X_0
    gap_cols: np.ndarray  # the variables they pin: x_1..x_N and S_0
    full: Transcription
    coll: Collocation
    carried: tuple[int, ...]  # integrand index of each running integral
    interval: Interval
    i_q: np.ndarray  # (n_q, N) each interval's stage variables, indices into w
    i_a: np.ndarray  # (n_a, N) each interval's parameters, indices into p
    #: the NLP with the intervals' outputs as symbols ``s`` (n_y, N): ``f = f_s`` and
    #: ``g = g_s`` once ``s`` is replaced by the outputs (SX in ``w_s, p_s, s``)
    w_s: Any
    p_s: Any
    s: Any
    f_s: Any
    g_s: Any
    interiors: ca.Function  # (w, p) -> (n_v, N) the intervals' solutions

    @property
    def n_intervals(self) -> int:
        """Intervals per period."""
        return self.i_period.size - 1

    def bounds(self, full: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
        """Scaled ``lbx, ubx, lbg, ubg`` of the condensed NLP from the full ones."""
        lbw, ubw, lbg, ubg = full
        lbx, ubx = np.full(self.n_w, -np.inf), np.full(self.n_w, np.inf)
        own = self.var_src >= 0
        lbx[own], ubx[own] = lbw[self.var_src[own]], ubw[self.var_src[own]]
        lbx[self.i_run[:, 0]] = ubx[self.i_run[:, 0]] = 0.0
        lo, hi = np.zeros(self.n_g), np.zeros(self.n_g)
        lo[self.row_g[0]], hi[self.row_g[0]] = lbg[self.row_g[1]], ubg[self.row_g[1]]
        lo[self.row_w[0]], hi[self.row_w[0]] = lbw[self.row_w[1]], ubw[self.row_w[1]]
        return lbx, ubx, lo, hi

    def equality(self) -> np.ndarray:
        """Per row, whether it is an equality in every configuration (fatrop's input)."""
        tr = self.full
        lo_hi = [self.bounds((tr.lbw, tr.ubw, tr.lbg, tr.ubg)), self.bounds(tr.limited)]
        return np.logical_and.reduce([b[2] == b[3] for b in lo_hi])

    def condense(self, w_full: np.ndarray, p_full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The condensed vector of a full scaled ``w`` and the NLP parameters with the
        Newton guess taken from it."""
        lay, d, n = self.full.layout, self.coll.degree, self.n_intervals
        w_full = np.asarray(w_full, dtype=float).ravel()
        w = np.zeros(self.n_w)
        own = self.var_src >= 0
        w[own] = w_full[self.var_src[own]]
        w[self.i_period] = w_full[lay.i_period[0]]
        w[self.i_start] = w_full[lay.i_x[:, :1]]
        if self.carried:
            integ = self._integrands(w_full, p_full)[list(self.carried)]
            shares = integ * np.tile(self.coll.quad, n)[None, :] / n
            per_interval = shares.reshape(len(self.carried), n, d).sum(axis=2)
            w[self.i_run[:, 1:]] = np.cumsum(per_interval, axis=1)
        x = w_full[lay.i_x]
        starts = np.repeat(x[:, 0:-1:d], d, axis=1)
        dx = (x[:, 1:] - starts).reshape(-1, n, d).transpose(2, 0, 1)  # (d, nx, N)
        z = w_full[lay.i_z].reshape(-1, n, d).transpose(2, 0, 1)  # (d, nz, N)
        guess = np.concatenate([dx.reshape(-1, n), z.reshape(-1, n)]).T.ravel()
        return w, np.concatenate([np.asarray(p_full, dtype=float).ravel(), guess])

    def expand(self, w: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The full scaled ``w`` of a condensed one: each interval's collocation solved."""
        lay, d, n = self.full.layout, self.coll.degree, self.n_intervals
        nx = lay.i_x.shape[0]
        v = np.asarray(self.interiors(w, p))  # (d (nx + nz), N)
        w_full = np.zeros(lay.n_w)
        own = self.var_src >= 0
        w_full[self.var_src[own]] = w[own]
        w_full[lay.i_period] = w[self.i_period[0]]
        xs = v[:d * nx].reshape(d, nx, n).transpose(1, 2, 0).reshape(nx, n * d)
        zs = v[d * nx:].reshape(d, -1, n).transpose(1, 2, 0).reshape(-1, n * d)
        w_full[lay.i_x[:, 1:]] = xs
        w_full[lay.i_z] = zs
        return w_full

    def _integrands(self, w_full: np.ndarray, p_full: np.ndarray) -> np.ndarray:
        """The integrands at every Radau point of a full ``w`` (columns)."""
        b = self.full.blocks
        fn = b.point.function.map(b.vars.shape[1])
        params = np.asarray(p_full).ravel()[b.i_params]
        params = np.tile(params[:, None], (1, b.vars.shape[1]))
        return np.asarray(fn(w_full[b.vars], params, b.deriv)[1])


@dataclass(frozen=True)
class Interval:
    """One interval as functions of its Radau points' unknowns ``v = (X_1..X_d,
    Z_1..Z_d)``, its stage variables ``q = (X_0, U, T, F_1..F_d)`` and its parameters
    ``a = (the model's parameters, guess, the tracking reference at its d points)`` (all
    scaled).

    ``residual(v, q, a)``: the collocation equations (dynamics and algebraic rows at the
    points), square in ``v``; ``outputs(v, q, a)``: ``y = (X_d, path rows, integrands,
    bounded states and algebraic variables, tracking sum)`` (:attr:`parts` gives each
    part's slice); ``solve(q, a) -> (y, v)``: Newton's method from the guess, then ``y``.
    """

    residual: ca.Function
    outputs: ca.Function
    solve: ca.Function
    parts: dict[str, slice]
    path: np.ndarray  # positions of the path rows among a point's rows
    n_v: int
    n_q: int
    n_a: int


def _solved_rows(point: Any, nx: int, nz: int) -> np.ndarray:
    """Which of a point's rows the interval solves: its dynamics and algebraic rows."""
    sizes = [t.expr.shape[0] for t in point.templates]
    start = np.cumsum([0, *sizes])
    solved = np.zeros(start[-1], dtype=bool)
    for i, t in enumerate(point.templates):
        if i == 0 or t.name == ALGEBRAIC_ROW:
            solved[start[i]:start[i + 1]] = True
    if int(solved.sum()) != nx + nz:
        raise ValueError(f"the condensed transcription solves a point's dynamics and its "
                         f"row {ALGEBRAIC_ROW!r} for the states and algebraic variables: "
                         f"{int(solved.sum())} rows for {nx + nz} unknowns")
    return solved


def interval(full: Transcription, coll: Collocation, dims: tuple[int, int, int, int],
             xbound: np.ndarray, zbound: np.ndarray, rootfinder: str = "newton") -> Interval:
    """The :class:`Interval` of ``full``'s point function; ``xbound``, ``zbound``: the
    state and algebraic components whose bounds become rows; ``rootfinder``: one of
    :data:`ROOTFINDERS`."""
    point = full.blocks.point
    nx, nz, nu, nf = dims
    d = coll.degree
    solved = _solved_rows(point, nx, nz)
    pos = np.arange(solved.size)
    v = ca.SX.sym("v", d * (nx + nz))
    q = ca.SX.sym("q", nx + nu + 1 + d * nf)
    n_par = point.function.size1_in(1)
    a = ca.SX.sym("a", n_par + v.shape[0] + d * nx)
    x0, u, period, params = q[:nx], q[nx:nx + nu], q[nx + nu], a[:n_par]
    ref = a[n_par + v.shape[0]:]
    xs = [v[j * nx:(j + 1) * nx] for j in range(d)]
    zs = [v[d * nx + j * nz:d * nx + (j + 1) * nz] for j in range(d)]
    fs = [q[nx + nu + 1 + j * nf:nx + nu + 1 + (j + 1) * nf] for j in range(d)]
    res, path, integ = [], [], []
    for j in range(d):
        vpt = ca.vertcat(period, xs[j], u, zs[j], fs[j], x0, *xs)
        rows, s = point.function(vpt, params, ca.DM(coll.deriv[:, j]))
        res.append(rows[pos[solved].tolist()])
        path.append(rows[pos[~solved].tolist()])
        integ.append(s)
    bounds = [xs[j][xbound.tolist()] for j in range(d - 1)] + [
        zs[j][zbound.tolist()] for j in range(d)]
    track = sum(ca.sumsqr(xs[j] - ref[j * nx:(j + 1) * nx]) for j in range(d))
    parts, y, start = {}, [], 0
    for name, expr in (("x_end", xs[-1]), ("path", ca.vertcat(*path)),
                       ("integrands", ca.vertcat(*integ)), ("bounds", ca.vertcat(*bounds)),
                       ("track", track)):
        parts[name] = slice(start, start + expr.shape[0])
        y.append(expr)
        start += expr.shape[0]
    residual = ca.Function("collocation", [v, q, a], [ca.vertcat(*res)])
    outputs = ca.Function("interval_outputs", [v, q, a], [ca.vertcat(*y)])
    newton = ca.rootfinder("interval", rootfinder, residual, ROOTFINDERS[rootfinder])
    qm, am = ca.MX.sym("q", q.shape[0]), ca.MX.sym("a", a.shape[0])
    v0 = (ca.vertcat(ca.repmat(qm[:nx], d, 1), ca.MX.zeros(d * nz, 1))
          + am[n_par:n_par + v.shape[0]])
    vm = newton(v0, qm, am)
    solved_ok = ca.norm_inf(residual(vm, qm, am)) <= NEWTON_CHECK
    y = ca.if_else(solved_ok, outputs(vm, qm, am), ca.DM.nan(start, 1))
    solve = ca.Function("interval_solve", [qm, am], [y, vm])
    return Interval(residual, outputs, solve, parts, pos[~solved], v.shape[0], q.shape[0],
                    a.shape[0])


def _bounded(full: Transcription, idx: np.ndarray) -> np.ndarray:
    """Which rows of ``idx`` (a variable's components at one point) have a finite bound
    in any configuration."""
    arrays = (full.lbw, full.ubw, full.limited[0], full.limited[1])
    return np.logical_or.reduce([np.isfinite(a[idx]) for a in arrays])


def _full_tail_rows(full: Transcription) -> np.ndarray:
    """Full rows that are neither a Radau point's nor a period tie: the start rows, then
    the periodicity rows, then the average rows (in that order)."""
    taken = np.zeros(full.layout.n_g, dtype=bool)
    taken[full.blocks.rows.ravel()] = True
    taken[full.layout.rows_of("period_tie")] = True
    return np.flatnonzero(~taken)


@dataclass
class _Builder:
    """Variables and rows of the condensed NLP as they are laid out."""

    n_w: int = 0
    n_g: int = 0
    rows: list = field(default_factory=list)  # expressions
    row_g: list = field(default_factory=list)
    row_w: list = field(default_factory=list)
    gap: list = field(default_factory=list)

    def take(self, size: int) -> np.ndarray:
        out = np.arange(self.n_w, self.n_w + size)
        self.n_w += size
        return out

    def add(self, expr: Any, src: tuple[str, np.ndarray] | None = None) -> None:
        """Rows ``expr``: gap rows (``src`` None) or rows with the bounds of the full
        row (``("g", rows)``) or variable (``("w", indices)``) they stand for."""
        size = expr.shape[0]
        idx = np.arange(self.n_g, self.n_g + size)
        self.rows.append(expr)
        self.n_g += size
        if src is None:
            self.gap.extend(idx)
        else:
            assert len(src[1]) == size
            (self.row_g if src[0] == "g" else self.row_w).extend(zip(idx, src[1], strict=True))


def _stages(b: _Builder, n: int, sizes: dict[str, int]) -> dict[str, list[np.ndarray]]:
    """Stage by stage: ``x_k = (X_k, T_k, S_k, Q_k)``, then ``u_k = (U_k, F_k)``."""
    st: dict[str, list[np.ndarray]] = {key: [] for key in sizes}
    for k in range(n + 1):
        for key in ("x", "t", "s", "q"):
            st[key].append(b.take(sizes[key]))
        if k < n:
            st["u"].append(b.take(sizes["u"]))
            st["f"].append(b.take(sizes["f"]))
    return st


def condensed_nlp(form: CycleFormulation, coll: Collocation, full: Transcription,
                  rootfinder: str = "newton") -> CondensedNlp:
    """The condensed NLP of ``form`` beside its full transcription ``full``
    (:func:`optimize.problem.transcriptions.layouts.general_layout` with collocation ``coll``).

    ``rootfinder`` solves each interval (:data:`ROOTFINDERS`).
    """
    lay, d = full.layout, coll.degree
    n = lay.i_u.shape[1]
    sizes = dims(form)
    nx, nz, nu, nf = sizes
    names = full.blocks.point.integrands
    carried = tuple(names.index(c) for c in form.constrained_averages)
    xbound = np.flatnonzero(_bounded(full, lay.i_x[:, 1]))
    zbound = np.flatnonzero(_bounded(full, lay.i_z[:, 0])) if nz else np.zeros(0, dtype=int)
    it = interval(full, coll, sizes, xbound, zbound, rootfinder)
    b = _Builder()
    st = _stages(b, n, {"x": nx, "t": 1, "s": nx, "q": len(carried), "u": nu, "f": d * nf})
    var_src = -np.ones(b.n_w, dtype=int)
    for k in range(n + 1):
        var_src[st["x"][k]] = lay.i_x[:, k * d]
        if k < n:
            var_src[st["u"][k]] = lay.i_u[:, k]
            var_src[st["f"][k]] = lay.i_f[:, k * d:(k + 1) * d].T.ravel()
    var_src[st["t"][0]] = lay.i_period[0]
    n_p_full = lay.n_p
    i_q = np.stack([np.concatenate([st["x"][k], st["u"][k], st["t"][k], st["f"][k]])
                    for k in range(n)], axis=1)
    i_a = np.stack([np.concatenate([full.blocks.i_params,
                                    n_p_full + k * it.n_v + np.arange(it.n_v),
                                    lay.i_p_ref[:, k * d + 1:(k + 1) * d + 1].T.ravel()])
                    for k in range(n)], axis=1)
    w, p = ca.SX.sym("w", b.n_w), ca.SX.sym("p", n_p_full + n * it.n_v)
    s = ca.SX.sym("s", it.parts["track"].stop, n)
    f_s = _rows_and_objective(form, coll, full, b, st, w, p, s, it, (xbound, zbound))
    g_s = ca.vertcat(*b.rows)
    # the NLP itself: each interval's outputs from its Newton solve, in place of s
    wm, pm = ca.MX.sym("w", b.n_w), ca.MX.sym("p", p.shape[0])
    qs = ca.reshape(wm[i_q.T.ravel().tolist()], it.n_q, n)
    as_ = ca.reshape(pm[i_a.T.ravel().tolist()], it.n_a, n)
    ys, vs = it.solve.map(n)(qs, as_)
    fg = ca.Function("f_g_s", [w, p, ca.vec(s)], [f_s, g_s])
    f, g = fg(wm, pm, ca.vec(ys))
    gap_cols = np.concatenate([np.concatenate([st[key][k] for key in ("x", "t", "s", "q")])
                               for k in range(1, n + 1)] + [st["s"][0]])
    return CondensedNlp(
        nlp={"x": wm, "p": pm, "f": f, "g": g}, n_w=b.n_w, n_g=b.n_g, n_p_full=n_p_full,
        var_src=var_src, row_g=np.array(b.row_g, dtype=int).reshape(-1, 2).T,
        row_w=np.array(b.row_w, dtype=int).reshape(-1, 2).T,
        i_period=np.concatenate(st["t"]), i_state=np.stack(st["x"], axis=1),
        i_start=np.stack(st["s"], axis=1),
        i_run=np.stack(st["q"], axis=1).reshape(len(carried), n + 1),
        gap_rows=np.array(b.gap, dtype=int), gap_cols=gap_cols, full=full, coll=coll,
        carried=carried, interval=it, i_q=i_q, i_a=i_a, w_s=w, p_s=p, s=s, f_s=f_s, g_s=g_s,
        interiors=ca.Function("interiors", [wm, pm], [vs]))


def _rows_and_objective(form: CycleFormulation, coll: Collocation, full: Transcription,
                        b: _Builder, st: dict, w: Any, p: Any, s: Any, it: Interval,
                        bounded: tuple[np.ndarray, np.ndarray]) -> Any:
    """Add the rows of every stage to ``b`` (in terms of the intervals' outputs ``s``)
    and return the objective."""
    lay, d = full.layout, coll.degree
    n = s.shape[1]
    names = full.blocks.point.integrands
    n_int = len(names)
    carried = [names.index(c) for c in form.constrained_averages]
    tail = _full_tail_rows(full)
    x_scale = ca.DM(form.scales.state)
    part = it.parts

    def integrand(k: int, j: int, i: int) -> Any:  # point j (1-based), integrand i
        return s[part["integrands"].start + (j - 1) * n_int + i, k]

    def shares(k: int, i: int) -> Any:
        return sum(share(coll, n, j, integrand(k, j, i)) for j in range(1, d + 1))

    start = [r.expr for r in form.start_rows(w[st["x"][0]] * x_scale)]
    n_start = sum(e.shape[0] for e in start)
    for k in range(n):
        b.add(ca.vertcat(w[st["x"][k + 1]] - s[part["x_end"], k],
                         w[st["t"][k + 1]] - w[st["t"][k]], w[st["s"][k + 1]] - w[st["s"][k]],
                         *[w[st["q"][k + 1][c]] - w[st["q"][k][c]] - shares(k, i)
                           for c, i in enumerate(carried)]))
        if k == 0:
            b.add(ca.vertcat(*start), ("g", tail[:n_start]))
            b.add(w[st["s"][0]] - w[st["x"][0]])
        b.add(s[part["path"], k], ("g", full.blocks.rows[it.path][:, k * d:(k + 1) * d]
                                   .T.ravel()))
        xb, zb = bounded
        b.add(s[part["bounds"], k], ("w", np.concatenate(
            [lay.i_x[xb, k * d + j] for j in range(1, d)]
            + [lay.i_z[zb, k * d + j] for j in range(d)]).astype(int)))
    periodic = ca.vertcat(*[r.expr for r in form.periodicity_rows(
        w[st["s"][n]] * x_scale, w[st["x"][n]] * x_scale)])
    b.add(periodic, ("g", tail[n_start:n_start + periodic.shape[0]]))
    if carried:
        b.add(ca.vertcat(*[r.expr for r in form.average_rows(
            {c: w[st["q"][n][i]] for i, c in enumerate(form.constrained_averages)})]),
            ("g", tail[n_start + periodic.shape[0]:]))
    par = {name: p[i] for name, i in lay.params.items()}
    averages = {a: sum(shares(k, i) for k in range(n)) for i, a in enumerate(form.averages)}
    fict = sum(integrand(k, j, len(form.averages)) for k in range(n)
               for j in range(1, d + 1)) / (n * d)
    reg = sum(form.control_cost(w[st["u"][k]] * ca.DM(form.scales.control))
              for k in range(n)) / n
    ref0 = p[lay.i_p_ref[:, 0].tolist()]
    track = (ca.sumsqr(w[st["x"][0]] - ref0) + ca.sum2(s[part["track"], :])) / (n * d + 1)
    return form.objective(par, averages, reg, track, fict)
