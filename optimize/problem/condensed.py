"""Condensed transcription: multiple shooting with the Radau collocation solved inside
each interval.

The same cycle OCP as :func:`optimize.problem.transcription.radau_collocation` (any
:class:`optimize.problem.interface.CycleFormulation`), with the states and algebraic
variables at the Radau points eliminated: each interval's collocation equations (the
dynamics rows and the formulation's point row named ``algebraic``, the DAE's algebraic
equations, as many as algebraic variables) are solved for them by Newton's method inside
the interval (a CasADi rootfinder, whose first and second derivatives come from the
implicit function theorem). The NLP's unknowns are stage by stage: the state
``x_k = (X_k, T_k, S_k, Q_k)`` (model state at the interval start, period, the cycle's
start state and the running integrals of the constrained cycle averages, all carried by
equality rows as in :func:`optimize.problem.transcription.stagewise_collocation`) and the
control ``u_k = (U_k, F_k1..F_kd)`` (control and fictitious forces at the Radau points).
Rows of stage ``k``: ``x_{k+1} - F(x_k, u_k)``, then (stage 0) the start rows and
``S_0 = X_0``, then the interval's point rows at its Radau points and the bounds of the
eliminated variables, as rows; the last stage has the periodicity and average rows.

The full layout stays the one the rest of the code reads (:class:`Layout` of the full
transcription): :meth:`CondensedNlp.condense` turns a full decision vector into a
condensed start, :meth:`CondensedNlp.expand` a condensed solution into the full vector
(the interval's collocation solved at it), and the index maps carry bounds and row
multipliers across (:mod:`optimize.solve.condensed_solve`). The Newton solve of an
interval starts from the NLP parameters ``guess``: the increments of the states from
the interval start and the algebraic variables of a full vector (the start's).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.collocation import Collocation
from optimize.problem.interface import CycleFormulation
from optimize.problem.transcription import (
    Transcription,
    _dims,
    _share,
    _tracking,
)

#: the point row that holds the DAE's algebraic equations (solved with the dynamics)
ALGEBRAIC_ROW = "algebraic"
#: Newton's method inside an interval: residual tolerance (scaled rows) and iteration limit
NEWTON_ABSTOL = 1e-10
NEWTON_MAX_ITER = 50


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
    i_q: np.ndarray  # (n_q, N + 1) Q_k
    gap_rows: np.ndarray  # rows x_{k+1} - F(x_k, u_k) and S_0 - X_0
    gap_cols: np.ndarray  # the variables they pin: x_1..x_N and S_0
    full: Transcription
    coll: Collocation
    carried: tuple[int, ...]  # integrand index of each running integral
    interiors: ca.Function  # (w, p) -> (d (nx + nz), N) the intervals' solutions

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
        lbx[self.i_q[:, 0]] = ubx[self.i_q[:, 0]] = 0.0
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
            w[self.i_q[:, 1:]] = np.cumsum(per_interval, axis=1)
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
        wind = np.full((1, b.vars.shape[1]), float(np.asarray(p_full).ravel()[b.i_wind]))
        return np.asarray(fn(w_full[b.vars], wind, b.deriv)[1])


@dataclass(frozen=True)
class _Interval:
    """One interval as functions of the Radau points' unknowns ``v = (X_1..X_d, Z_1..Z_d)``
    and ``q = (X_0, U, T, F_1..F_d, wind)`` (scaled): the rootfinder of the collocation
    equations and the rows and integrands at the points."""

    solve: ca.Function  # (v0, q) -> v
    rows: ca.Function  # (v, q) -> (path rows (n_path d), integrands (n_int, d))
    path: np.ndarray  # positions of the path rows among a point's rows
    n_v: int


def _interval(full: Transcription, coll: Collocation, dims: tuple[int, int, int, int]
              ) -> _Interval:
    point = full.blocks.point
    nx, nz, nu, nf = dims
    d = coll.degree
    names = ["dynamics"] + [t.name for t in point.templates[1:]]
    sizes = [t.expr.shape[0] for t in point.templates]
    start = np.cumsum([0, *sizes])
    solved = [i for i, name in enumerate(names) if name in ("dynamics", ALGEBRAIC_ROW)]
    pos = np.arange(start[-1])
    in_solved = np.zeros(start[-1], dtype=bool)
    for i in solved:
        in_solved[start[i]:start[i + 1]] = True
    if int(in_solved.sum()) != nx + nz:
        raise ValueError(f"the condensed transcription solves a point's dynamics and its "
                         f"row {ALGEBRAIC_ROW!r} for the states and algebraic variables: "
                         f"{int(in_solved.sum())} rows for {nx + nz} unknowns")
    v = ca.SX.sym("v", d * (nx + nz))
    q = ca.SX.sym("q", nx + nu + 1 + d * nf + 1)
    x0, u, period = q[:nx], q[nx:nx + nu], q[nx + nu]
    wind = q[-1]
    xs = [v[j * nx:(j + 1) * nx] for j in range(d)]
    zs = [v[d * nx + j * nz:d * nx + (j + 1) * nz] for j in range(d)]
    fs = [q[nx + nu + 1 + j * nf:nx + nu + 1 + (j + 1) * nf] for j in range(d)]
    res, path, integ = [], [], []
    for j in range(d):
        vpt = ca.vertcat(period, xs[j], u, zs[j], fs[j], x0, *xs)
        rows, s = point.function(vpt, wind, ca.DM(coll.deriv[:, j]))
        res.append(rows[pos[in_solved].tolist()])
        path.append(rows[pos[~in_solved].tolist()])
        integ.append(s)
    g = ca.Function("collocation", [v, q], [ca.vertcat(*res)])
    solve = ca.rootfinder("interval", "newton", g, {
        "abstol": NEWTON_ABSTOL, "abstolStep": 0.0, "max_iter": NEWTON_MAX_ITER,
        "error_on_fail": True})
    rows_fn = ca.Function("interval_rows", [v, q], [ca.vertcat(*path), ca.horzcat(*integ)])
    return _Interval(solve, rows_fn, pos[~in_solved], v.shape[0])


def _sx(fn: Any, *sizes: int) -> ca.Function:
    """``fn`` (of SX columns of ``sizes``) as a CasADi function, to call on MX."""
    args = [ca.SX.sym(f"a{i}", size) for i, size in enumerate(sizes)]
    return ca.Function("part", args, [fn(*args)])


def _full_tail_rows(full: Transcription) -> np.ndarray:
    """Full rows that are neither a Radau point's nor a period tie: the start rows, then
    the periodicity rows, then the average rows (in that order)."""
    n_g = full.layout.n_g
    taken = np.zeros(n_g, dtype=bool)
    taken[full.blocks.rows.ravel()] = True
    taken[full.layout.rows_of("period_tie")] = True
    return np.flatnonzero(~taken)


@dataclass
class _Builder:
    """Variables and rows of the condensed NLP as they are laid out."""

    n_w: int = 0
    rows: list = None  # expressions
    n_g: int = 0
    row_g: list = None
    row_w: list = None
    gap: list = None

    def __post_init__(self) -> None:
        self.rows, self.row_g, self.row_w, self.gap = [], [], [], []

    def take(self, size: int) -> np.ndarray:
        out = np.arange(self.n_w, self.n_w + size)
        self.n_w += size
        return out

    def add(self, expr: Any, kind: str = "gap", src: np.ndarray | None = None) -> None:
        size = expr.shape[0]
        idx = np.arange(self.n_g, self.n_g + size)
        self.rows.append(expr)
        self.n_g += size
        if kind == "gap":
            self.gap.extend(idx)
        else:
            assert src is not None and len(src) == size
            (self.row_g if kind == "g" else self.row_w).extend(zip(idx, src, strict=True))


def _bounded(full: Transcription, idx: np.ndarray) -> np.ndarray:
    """Which rows of ``idx`` (a variable's components at one point) have a finite bound
    in any configuration."""
    arrays = (full.lbw, full.ubw, full.limited[0], full.limited[1])
    return np.logical_or.reduce([np.isfinite(a[idx]) for a in arrays])


def condensed_nlp(form: CycleFormulation, coll: Collocation, full: Transcription
                  ) -> CondensedNlp:
    """The condensed NLP of ``form`` beside its full transcription ``full``
    (:func:`optimize.problem.transcription.radau_collocation` with collocation ``coll``)."""
    lay, d = full.layout, coll.degree
    n = lay.i_u.shape[1]
    dims = _dims(form)
    nx, nz, nu, nf = dims
    names = full.blocks.point.integrands
    carried = tuple(names.index(c) for c in form.constrained_averages)
    nq = len(carried)
    it = _interval(full, coll, dims)
    b = _Builder()
    st = {"x": [], "t": [], "s": [], "q": [], "u": [], "f": []}
    for k in range(n + 1):
        for key, size in (("x", nx), ("t", 1), ("s", nx), ("q", nq)):
            st[key].append(b.take(size))
        if k < n:
            st["u"].append(b.take(nu))
            st["f"].append(b.take(d * nf))
    var_src = -np.ones(b.n_w, dtype=int)
    for k in range(n + 1):
        var_src[st["x"][k]] = lay.i_x[:, k * d]
        if k < n:
            var_src[st["u"][k]] = lay.i_u[:, k]
            var_src[st["f"][k]] = lay.i_f[:, k * d:(k + 1) * d].T.ravel()
    var_src[st["t"][0]] = lay.i_period[0]
    w = ca.MX.sym("w", b.n_w)
    n_p_full = lay.n_p
    p = ca.MX.sym("p", n_p_full + n * it.n_v)
    wind = p[lay.params["wind_ref_m_s"]]
    xbound = np.flatnonzero(_bounded(full, lay.i_x[:, 1]))
    zbound = np.flatnonzero(_bounded(full, lay.i_z[:, 0])) if nz else np.zeros(0, dtype=int)
    tail = _full_tail_rows(full)
    x_scale = ca.DM(form.scales.state)
    start_fn = _sx(lambda x0: ca.vertcat(*[r.expr for r in form.start_rows(x0 * x_scale)]), nx)
    per_fn = _sx(lambda a, e: ca.vertcat(*[r.expr for r in form.periodicity_rows(
        a * x_scale, e * x_scale)]), nx, nx)
    n_start, n_per = start_fn.size1_out(0), per_fn.size1_out(0)
    xs_phys = [w[st["x"][0]] * x_scale]
    sums = {a: 0 for a in form.averages}
    fict, reg = 0, 0
    cost_fn = _sx(lambda u: form.control_cost(u * ca.DM(form.scales.control)), nu)
    interiors = []
    for k in range(n):
        q = ca.vertcat(w[st["x"][k]], w[st["u"][k]], w[st["t"][k]], w[st["f"][k]], wind)
        guess = p[n_p_full + k * it.n_v:n_p_full + (k + 1) * it.n_v]
        v0 = ca.vertcat(ca.repmat(w[st["x"][k]], d, 1), ca.MX.zeros(d * nz, 1)) + guess
        v = it.solve(v0, q)
        interiors.append(v)
        path, integ = it.rows(v, q)
        x_end = v[(d - 1) * nx:d * nx]
        dq = [sum(_share(coll, n, j, integ[c, j - 1]) for j in range(1, d + 1)) for c in carried]
        b.add(ca.vertcat(w[st["x"][k + 1]] - x_end, w[st["t"][k + 1]] - w[st["t"][k]],
                         w[st["s"][k + 1]] - w[st["s"][k]],
                         *[w[st["q"][k + 1][i]] - w[st["q"][k][i]] - dq[i]
                           for i in range(nq)]))
        if k == 0:
            b.add(start_fn(w[st["x"][0]]), "g", tail[:n_start])
            b.add(w[st["s"][0]] - w[st["x"][0]])
        b.add(path, "g", full.blocks.rows[it.path][:, k * d:(k + 1) * d].T.ravel())
        for j in range(1, d):
            b.add(v[(j - 1) * nx + xbound], "w", lay.i_x[xbound, k * d + j])
        for j in range(d):
            b.add(v[d * nx + j * nz + zbound], "w", lay.i_z[zbound, k * d + j])
        for j in range(1, d + 1):
            xs_phys.append(v[(j - 1) * nx:j * nx] * x_scale)
            for i, a in enumerate(form.averages):
                sums[a] += _share(coll, n, j, integ[i, j - 1])
            fict += integ[len(form.averages), j - 1] / (n * d)
        reg += cost_fn(w[st["u"][k]]) / n
    b.add(per_fn(w[st["s"][n]], w[st["x"][n]]), "g", tail[n_start:n_start + n_per])
    if nq:
        avg_fn = _sx(lambda qn: ca.vertcat(*[r.expr for r in form.average_rows(
            {c: qn[i] for i, c in enumerate(form.constrained_averages)})]), nq)
        b.add(avg_fn(w[st["q"][n]]), "g", tail[n_start + n_per:])
    track = _tracking(form, p, lay.i_p_ref, xs_phys)
    f = _objective(form, p, n_p_full, sums, reg, track, fict, lay.params)
    gap_cols = np.concatenate([np.concatenate([st[key][k] for key in ("x", "t", "s", "q")])
                               for k in range(1, n + 1)] + [st["s"][0]])
    return CondensedNlp(
        nlp={"x": w, "p": p, "f": f, "g": ca.vertcat(*b.rows)}, n_w=b.n_w, n_g=b.n_g,
        n_p_full=n_p_full, var_src=var_src,
        row_g=np.array(b.row_g, dtype=int).reshape(-1, 2).T,
        row_w=np.array(b.row_w, dtype=int).reshape(-1, 2).T,
        i_period=np.concatenate(st["t"]), i_state=np.stack(st["x"], axis=1),
        i_start=np.stack(st["s"], axis=1), i_q=np.stack(st["q"], axis=1).reshape(nq, n + 1),
        gap_rows=np.array(b.gap, dtype=int), gap_cols=gap_cols, full=full, coll=coll,
        carried=carried,
        interiors=ca.Function("interiors", [w, p], [ca.horzcat(*interiors)]))


def _objective(form: CycleFormulation, p: Any, n_p_full: int, sums: dict, reg: Any,
               track: Any, fict: Any, params: dict[str, int]) -> Any:
    """The formulation's objective (through an SX function, called on the MX sums)."""
    ps = ca.SX.sym("p", n_p_full)
    avg = ca.SX.sym("avg", len(sums))
    r, t, fi = ca.SX.sym("reg"), ca.SX.sym("track"), ca.SX.sym("fict")
    par = {name: ps[i] for name, i in params.items()}
    expr = form.objective(par, {a: avg[i] for i, a in enumerate(sums)}, r, t, fi)
    fn = ca.Function("objective", [ps, avg, r, t, fi], [expr])
    return fn(p[:n_p_full], ca.vertcat(*sums.values()), reg, track, fict)
