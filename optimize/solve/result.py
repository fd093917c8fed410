"""Plain-data results of an OCP solve (picklable: they cross process boundaries)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from optimize.cycles import cycle_metrics, cycle_quadrature
from optimize.problem.ocp import Ocp
from optimize.problem.part import FRAME_COLUMNS, near
from optimize.problem.scenario import Scenario
from optimize.solve.nlp_solver import RawSolve
from optimize.solve.starts.fill import KEYS, fill

#: the layout's indices of each start array (:data:`optimize.solve.starts.fill.KEYS`)
LAYOUT = {"x": "i_x", "u": "i_u", "z": "i_z", "fict": "i_f"}


@dataclass(frozen=True)
class Solution:
    """Scaled primal and dual vectors of a solve, to warm-start the next one.

    Only valid for an :class:`optimize.problem.ocp.Ocp` with the same ``n_intervals``
    and ``degree`` (checked by :func:`optimize.solve.solve.solve`). ``p`` (the NLP
    parameters it solves) and ``drive_limits`` (whether the drive limits bounded it)
    let the next solve predict its optimum (:mod:`optimize.solve.starts.predictor`); None
    where unknown (a stored solve, a carried-over one).
    """

    w: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    n_intervals: int
    degree: int
    p: np.ndarray | None = None
    drive_limits: bool | None = None


@dataclass(frozen=True)
class OcpResult:
    """Outcome of one scenario.

    Attributes
    ----------
    scenario : Scenario
    status : str
        The solver's own return status of the final solve (IPOPT's, e.g.
        ``"Solve_Succeeded"``, or fatrop's return flag and its meaning).
    success : bool
        The solver reported success (converged or acceptable level).
    iterations : int
        Solver iterations, all stages/retries included.
    wall_time_s : float
        Wall time of the solver calls [s], all stages/retries included.
    objective : float
        NLP objective at the solution [power scale, regularization included].
    period_s : float
        Cycle period [s].
    avg_p_elec_w, avg_p_mech_w : float
        Average electrical and mechanical power over the cycle [W]
        (negative = generated).
    periodicity_error : float
        Largest scaled residual of the periodicity constraints [-].
    max_violation : float
        Largest scaled violation of any constraint [-].
    trajectory : pandas.DataFrame
        One row per Radau point (``time_s`` in ``(0, T]``): the columns of
        :func:`optimize.problem.part.trajectory_columns` of the OCP's parts (time,
        interval, weight, states, controls, algebraic variables, the parts' outputs);
        ``weight`` are the quadrature weights
        (:func:`optimize.cycles.cycle_quadrature` gives a cycle average).
    warm : Solution
        Primal/dual vectors to warm-start the next solve.
    stages : tuple of dict
        Per-stage log of a cold start (name, status, iterations, wall_time_s);
        one entry per solver call otherwise.
    active_bounds : tuple of str
        Bounds the optimum sits on (:func:`active_bounds`): ``period_min``,
        ``period_max``, ``tether_length_min``, ``tether_length_max``,
        ``ground_clearance``, ``airspeed_min``, ``airspeed_max``, ``tether_force_limit``,
        ``reel_acceleration_limit``, ``reel_jerk_limit``, ``speed_limit``, ``torque_limit``,
        ``envelope_limit``, ``p_elec_limit``.
    slack_fraction : float
        Fraction of the cycle time with zero tether tension [-] (:func:`slack_fraction`).
    figures : dict of float
        The parts' own figures of the cycle (:func:`part_figures`: the winding's peak
        temperature [degC] and its margin [K] with the thermal part), by name.
    start : str
        How the final solve was started: ``"warm start"`` (from a neighbouring
        solution), ``"stored guess"`` (:mod:`optimize.solve.starts.stored_guess`) or
        ``"homotopy"``.
    intermediates : tuple of dict
        The solves on the way to this scenario that are not its own
        (:mod:`optimize.solve.starts.continuation`: intermediate points and the
        capped tries whose step was halved), each with its ``step``, ``status``,
        ``success``, ``iterations`` and times; not in ``iterations``.
    """

    scenario: Scenario
    status: str
    success: bool
    iterations: int
    wall_time_s: float
    objective: float
    period_s: float
    avg_p_elec_w: float
    avg_p_mech_w: float
    periodicity_error: float
    max_violation: float
    trajectory: pd.DataFrame
    warm: Solution
    stages: tuple[dict, ...]
    start: str = "warm start"
    active_bounds: tuple[str, ...] = ()
    slack_fraction: float = 0.0
    figures: Mapping[str, float] = field(default_factory=dict)
    intermediates: tuple[dict, ...] = ()

    @property
    def intermediate_points(self) -> int:
        """Converged intermediate points on the way to this scenario."""
        return sum(1 for s in self.intermediates if s["success"])

    @property
    def intermediate_iterations(self) -> int:
        """Solver iterations on the way to this scenario, besides its own."""
        return int(sum(s["iterations"] for s in self.intermediates))


def trajectory_frame(ocp: Ocp, w_scaled: np.ndarray,
                     parameters: Mapping[str, float] | float | None) -> pd.DataFrame:
    """Trajectory at every Radau point of a scaled decision vector: time, interval,
    quadrature weight, the model's states, controls and algebraic variables by name, and
    the parts' outputs (``trajectory_outputs``): the columns of
    :func:`optimize.problem.part.trajectory_columns` of the OCP's parts, in that order."""
    sol = ocp.unpack(w_scaled)
    n, d = ocp.n_intervals, ocp.coll.degree
    x = sol["x"][:, 1:]  # states at the Radau points
    z = sol["z"]
    u = np.repeat(sol["u"], d, axis=1)
    interval = np.repeat(np.arange(n), d)
    h = sol["period_s"] / n
    tau = np.tile(ocp.coll.tau[1:], n)
    frame = dict(zip(FRAME_COLUMNS, (h * (interval + tau), interval,
                                     np.tile(ocp.coll.quad, n) / n), strict=True))
    dae = ocp.dae
    for names, arr in ((dae.states.names, x), (dae.controls.names, u),
                       (dae.algebraic.names, z)):
        for i, name in enumerate(names):
            frame[name] = arr[i]
    params = list(ocp.model_parameters(parameters).values())
    frame.update(ocp.formulation.trajectory_outputs(x, u, z, params))
    return pd.DataFrame(frame)


def carry_over(src: Ocp, solution: Solution, dst: Ocp,
               parameters: Mapping[str, float] | None = None) -> Solution:
    """A solution of ``src`` in the layout of ``dst``: the same problem in another
    transcription (:func:`optimize.problem.ocp.twin`), or one with more parts, whose
    variables their parts fill (:func:`optimize.solve.starts.fill.fill`, at the model's
    ``parameters`` of the solution, :attr:`optimize.problem.scenario.Scenario.parameters`).

    The primal point through the physical variables by name (``dst`` fills its
    copies); the multipliers of the variables both have and of the rows with the same
    name and count; zero for the others.
    """
    sol = src.unpack(solution.w)
    period = float(sol["period_s"])
    arrays, known = {}, set()
    lam_x = np.zeros(dst.layout.n_w)
    for group, key in KEYS.items():
        ours, theirs = getattr(src.dae, group), getattr(dst.dae, group)
        i_src, i_dst = getattr(src.layout, LAYOUT[key]), getattr(dst.layout, LAYOUT[key])
        arrays[key] = np.zeros((theirs.size, sol[key].shape[1]))
        for i, name in enumerate(theirs.names):
            if name in ours.names:
                j = ours.index(name)
                arrays[key][i] = sol[key][j]
                lam_x[i_dst[i]] = solution.lam_x[i_src[j]]
                known.add(name)
    if len(known) < sum(getattr(dst.dae, group).size for group in KEYS):
        if parameters is None:
            raise ValueError("the destination has variables the solution has not: their "
                             "parts fill them at the model's parameters (parameters)")
        arrays = fill(dst, arrays, period, parameters, known)
    w = dst.pack(arrays["x"], arrays["z"], arrays["u"], arrays["fict"], period)
    s_lay, d_lay = src.layout, dst.layout
    lam_x[d_lay.i_period[0]] = solution.lam_x[s_lay.i_period].sum()
    lam_g = np.zeros(d_lay.n_g)
    for name, rows in d_lay.rows.items():
        if s_lay.rows_of(name).size == rows.size:
            lam_g[rows] = solution.lam_g[s_lay.rows_of(name)]
    return Solution(w=w, lam_x=lam_x, lam_g=lam_g, n_intervals=solution.n_intervals,
                    degree=solution.degree)


#: tension below this fraction of the kite's weight counts as a slack tether
SLACK_TENSION_FRACTION = 1e-3


def active_bounds(ocp: Ocp, traj: pd.DataFrame, period_s: float, drive_limits: bool,
                  bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> tuple[str, ...]:
    """Names of the bounds the solution sits on: the period's, then each part's
    (:meth:`optimize.problem.part.Part.active_bounds`: tether length, ground, the kite's
    airspeed and tether-force limits, the winch's, the drive's, the winding's).

    Parameters
    ----------
    ocp : Ocp
    traj : pandas.DataFrame
        :func:`trajectory_frame` of the solution.
    period_s : float
        Its period [s].
    drive_limits : bool
        Whether the drive limits applied.
    bounds : tuple
        The scaled ``lbx, ubx, lbg, ubg`` of the solve (a fixed period is not a bound).
    """
    out = []
    i = ocp.layout.i_period[0]
    if bounds[0][i] != bounds[1][i]:  # a fixed period is not a bound
        lo, hi = ocp.formulation.period_bounds()
        out += [n for n, b in (("period_min", lo), ("period_max", hi)) if near(period_s, b)]
    for part in getattr(ocp.formulation, "parts", ()):
        out += part.active_bounds(traj, drive_limits)
    return tuple(out)


def part_figures(ocp: Ocp, traj: pd.DataFrame) -> dict[str, float]:
    """Each part's own figures of a solved cycle (:meth:`optimize.problem.part.Part.figures`)
    from its :func:`trajectory_frame`, by name."""
    out: dict[str, float] = {}
    for part in getattr(ocp.formulation, "parts", ()):
        out.update({name: float(value) for name, value in part.figures(traj).items()})
    return out


def slack_fraction(ocp: Ocp, traj: pd.DataFrame) -> float:
    """Fraction of the cycle time [-] with tension below :data:`SLACK_TENSION_FRACTION`
    of the kite's weight (quadrature weights of the Radau points)."""
    kite = ocp.dae.kite
    slack = traj["tension_n"].to_numpy() < SLACK_TENSION_FRACTION * kite.mass_kg * kite.g_m_s2
    return cycle_quadrature(traj["weight"], slack)


def make_result(
    ocp: Ocp,
    scenario: Scenario,
    raw: RawSolve,
    p: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    stages: list[dict],
    start: str = "warm start",
    intermediates: tuple[dict, ...] = (),
) -> OcpResult:
    """Assemble an :class:`OcpResult` from the final solver call, the stage log and the
    solves on the way (``intermediates``)."""
    traj = trajectory_frame(ocp, raw.w, scenario.parameters)
    g = ocp.constraint_values(raw.w, p)
    lbg, ubg = bounds[2], bounds[3]
    viol_g = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
    viol_x = np.maximum(np.maximum(bounds[0] - raw.w, raw.w - bounds[1]), 0.0)
    per = float(np.max(np.abs(g[ocp.layout.rows_of("periodic")])))
    period_s = float(ocp.unpack(raw.w)["period_s"])
    metrics = cycle_metrics(traj)
    return OcpResult(
        scenario=scenario,
        status=raw.status,
        success=raw.success,
        iterations=int(sum(s["iterations"] for s in stages)),
        wall_time_s=float(sum(s["wall_time_s"] for s in stages)),
        objective=raw.objective,
        period_s=period_s,
        avg_p_elec_w=metrics["avg_p_elec_w"],
        avg_p_mech_w=metrics["avg_p_mech_w"],
        periodicity_error=per,
        max_violation=float(max(viol_g.max(initial=0.0), viol_x.max(initial=0.0))),
        trajectory=traj,
        warm=Solution(
            w=raw.w, lam_x=raw.lam_x, lam_g=raw.lam_g,
            n_intervals=ocp.n_intervals, degree=ocp.coll.degree, p=p,
            drive_limits=scenario.drive_limits,
        ),
        stages=tuple(stages),
        start=start,
        active_bounds=active_bounds(ocp, traj, period_s, scenario.drive_limits, bounds),
        slack_fraction=slack_fraction(ocp, traj),
        figures=part_figures(ocp, traj),
        intermediates=tuple(intermediates),
    )
