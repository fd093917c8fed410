"""Direct Radau collocation of the cycle OCP into one scaled NLP.

Takes the :class:`optimize.problem.formulation.Formulation` (what is optimized)
and a :class:`optimize.problem.options.Discretization` (how finely) and lays out
the decision vector ``w``, the constraint vector ``g`` and the parameters ``p``.
Each decision variable is stored divided by its typical magnitude.

Decision vector (scaled), in this order: one copy of the period ``T`` per
interval (tied by equality rows, so no variable couples every interval); states at the
``N d + 1`` grid points (interval starts and the Radau points; the last Radau
point of an interval is the start of the next); algebraic variables at the
``N d`` Radau points; one control per interval; fictitious forces/moments at
the ``N d`` Radau points (homotopy only; fixed at zero otherwise).

Constraint vector: per Radau point the collocation rows of the dynamics then the
formulation's point rows; then the period ties, the start rows, the periodicity
rows and the rows on cycle averages. :attr:`Layout.rows` finds rows by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from optimize.model import kite_model as km
from optimize.problem.collocation import Collocation
from optimize.problem.formulation import PARAM_NAMES, Formulation, Row
from optimize.problem.options import Discretization


@dataclass
class Layout:
    """Index bookkeeping of the scaled decision, constraint and parameter vectors."""

    n_points: int  # grid points with states (N d + 1)
    n_coll: int  # Radau points (N d)
    i_period: np.ndarray  # (N,) one copy of the period per interval, all equal
    i_x: np.ndarray  # (NX, n_points) indices into w
    i_z: np.ndarray  # (NZ, n_coll)
    i_u: np.ndarray  # (NU, N)
    i_f: np.ndarray  # (NF, n_coll)
    scale_w: np.ndarray  # w_physical = scale_w * w_scaled
    n_w: int
    n_g: int
    n_p: int
    i_p_ref: np.ndarray  # (NX, n_points) reference trajectory in p
    rows: dict[str, np.ndarray] = field(default_factory=dict)  # name -> indices into g

    def rows_of(self, name: str) -> np.ndarray:
        """Indices into ``g`` of the rows named ``name`` (empty when the NLP has none)."""
        return self.rows.get(name, np.zeros(0, dtype=int))


@dataclass
class Transcription:
    """A transcribed NLP: CasADi problem, layout and scaled base bounds.

    ``lbw, ubw, lbg, ubg`` hold without the drive limits, ``limited`` with them
    (both with the period free and the fictitious forces free).
    """

    nlp: dict
    layout: Layout
    lbw: np.ndarray
    ubw: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    limited: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


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


def radau_collocation(form: Formulation, disc: Discretization, coll: Collocation
                      ) -> Transcription:
    """Transcribe ``form`` by Radau collocation on ``disc.n_intervals`` intervals."""
    sc = form.scales
    n, d = disc.n_intervals, coll.degree
    nx, nz, nu, nf = km.NX, km.NZ, km.NU, km.NF
    n_points, n_coll = n * d + 1, n * d

    # ---- layout of w
    counter = iter(range(10**9))
    i_period = np.array([next(counter) for _ in range(n)])
    i_x = np.array([[next(counter) for _ in range(nx)] for _ in range(n_points)]).T
    i_z = np.array([[next(counter) for _ in range(nz)] for _ in range(n_coll)]).T
    i_u = np.array([[next(counter) for _ in range(nu)] for _ in range(n)]).T
    i_f = np.array([[next(counter) for _ in range(nf)] for _ in range(n_coll)]).T
    n_w = next(counter)
    scale_w = np.ones(n_w)
    scale_w[i_period] = sc.period_s
    scale_w[i_x] = sc.state[:, None]
    scale_w[i_z] = sc.algebraic[:, None]
    scale_w[i_u] = sc.control[:, None]
    scale_w[i_f] = sc.fictitious[:, None]

    n_par = len(PARAM_NAMES)
    n_p = n_par + nx * n_points
    i_p_ref = n_par + np.arange(nx * n_points).reshape(n_points, nx).T

    w = ca.SX.sym("w", n_w)
    p = ca.SX.sym("p", n_p)
    par = dict(zip(PARAM_NAMES, (p[i] for i in range(n_par)), strict=True))
    ws = w * ca.DM(scale_w)

    def col(idx: np.ndarray, k: int) -> ca.SX:
        return ws[[int(i) for i in idx[:, k]]]

    xs = [col(i_x, k) for k in range(n_points)]
    zs = [col(i_z, k) for k in range(n_coll)]
    us = [col(i_u, k) for k in range(n)]
    fs = [col(i_f, k) for k in range(n_coll)]

    rows = _Rows()
    inv_sx = ca.DM(1.0 / sc.state)
    p_elec_avg, p_mech_avg, reg, track, fict_pen, torque_sq_avg = 0, 0, 0, 0, 0, 0
    for k in range(n):
        u_k = us[k]
        h = ws[int(i_period[k])] / n
        reg += form.control_cost(u_k) / n
        for j in range(1, d + 1):
            ip = k * d + j  # grid point of this Radau point
            ic = k * d + j - 1  # Radau point index
            x_kj, z_kj = xs[ip], zs[ic]
            xp = sum(coll.deriv[r, j - 1] * xs[k * d + r] for r in range(d + 1))
            rows.add(Row("dynamics", (xp - h * form.ode(x_kj, u_k, z_kj)) * inv_sx))
            point = form.point(x_kj, u_k, z_kj, fs[ic], par["wind_ref_m_s"])
            for row in point.rows:
                rows.add(row)
            p_elec_avg += coll.quad[j - 1] * point.p_elec_w / n
            p_mech_avg += coll.quad[j - 1] * point.p_mech_w / n
            torque_sq_avg += coll.quad[j - 1] * point.torque_sq / n
            fict_pen += point.fict_sq / n_coll
    for k in range(n_points):
        ref = p[[int(i) for i in i_p_ref[:, k]]]
        track += ca.sumsqr(xs[k] * inv_sx - ref) / n_points

    # one period copy per interval keeps the KKT matrix banded (no dense period column)
    rows.add(Row("period_tie", ca.vertcat(*[(ws[int(i_period[k + 1])] - ws[int(i_period[k])])
                                            / sc.period_s for k in range(n - 1)])))
    for row in (*form.start_rows(xs[0]), *form.periodicity_rows(xs[0], xs[-1]),
                *form.average_rows(torque_sq_avg)):
        rows.add(row)

    objective = form.objective(par, p_elec_avg, p_mech_avg, reg, track, fict_pen)
    nlp = {"x": w, "p": p, "f": objective, "g": ca.vertcat(*rows.exprs)}

    # ---- base bounds (physical, then scaled)
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

    layout = Layout(
        n_points=n_points, n_coll=n_coll, i_period=i_period, i_x=i_x, i_z=i_z, i_u=i_u,
        i_f=i_f, scale_w=scale_w, n_w=n_w, n_g=rows.n, n_p=n_p, i_p_ref=i_p_ref,
        rows={name: np.array(idx, dtype=int) for name, idx in rows.index.items()},
    )
    return Transcription(
        nlp=nlp, layout=layout, lbw=lbw / scale_w, ubw=ubw / scale_w,
        lbg=np.array(rows.lo), ubg=np.array(rows.hi),
        limited=(lbw_lim / scale_w, ubw_lim / scale_w, np.array(rows.lo_lim),
                 np.array(rows.hi_lim)),
    )
