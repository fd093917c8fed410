"""Trust checks of an optimal cycle: mesh refinement and an independent simulation.

* **Mesh check** (:func:`mesh_check`): the same scenario on an OCP with twice
  the intervals, warm-started from the coarse solution (primal values and
  bound multipliers) interpolated onto the fine grid; reports the relative
  change of the average electrical and mechanical power; it should be
  less than 1 %.
* **Simulation check** (:func:`simulation_check`): the optimal controls
  (piecewise constant per interval) are integrated with CasADi's CVODES
  (variable-order BDF, its own error control; nothing shared with the Radau
  collocation but the model equations) on the explicit ODE of the kite (the
  algebraic variables solved from the DAE at every right-hand-side call).
  Two figures: the *interval defect* (each interval integrated from the
  collocation state at its start; the largest deviation at the Radau points)
  and the *open-loop* run over a whole period from the initial state, with
  its *periodicity error* ``|x(T) - x(0)|`` on the periodic states.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from kernel.names import WIND_SPEED
from optimize.analysis.result_check import MAX_DEFECT_SCALED
from optimize.problem.kite_part import POSITION_STATES
from optimize.problem.ocp import Ocp, grid_times
from optimize.problem.scenario import Scenario
from optimize.service.builder import OcpBackend
from optimize.service.executors import run_tasks
from optimize.service.plan import middle_index
from optimize.solve.result import OcpResult
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.solve.starts.remesh import solve_interpolated


@dataclass(frozen=True)
class MeshCheck:
    """Result of :func:`mesh_check`.

    Attributes
    ----------
    scenario : str
    n_intervals, n_intervals_fine : int
    status : str
        IPOPT status on the fine mesh.
    success : bool
    iterations : int
    wall_time_s : float
        Fine-mesh solve wall time [s] (build excluded).
    route : str
        ``"interpolated warm start"`` or ``"cold start"`` (when the first failed).
    avg_p_elec_w, avg_p_elec_fine_w, avg_p_mech_w, avg_p_mech_fine_w : float
        Average powers on the coarse and fine mesh [W].
    period_s, period_fine_s : float
        Periods [s].
    rel_change_p_elec, rel_change_p_mech : float
        ``|fine - coarse| / |coarse|`` [-]; NaN if the fine solve failed.
    """

    scenario: str
    n_intervals: int
    n_intervals_fine: int
    status: str
    success: bool
    iterations: int
    wall_time_s: float
    route: str
    avg_p_elec_w: float
    avg_p_elec_fine_w: float
    avg_p_mech_w: float
    avg_p_mech_fine_w: float
    period_s: float
    period_fine_s: float
    rel_change_p_elec: float
    rel_change_p_mech: float


@dataclass(frozen=True)
class SimulationCheck:
    """Result of :func:`simulation_check`.

    Attributes
    ----------
    scenario : str
    integrator : str
    interval_defect_position_m : float
        Largest |r_sim - r_coll| at the Radau points, each interval integrated
        from the collocation state at its start [m].
    interval_defect_scaled : float
        Same over all states, each divided by its typical magnitude [-].
    open_loop_position_m : float
        Largest |r_sim - r_coll| over one period integrated from x(0) only [m].
    periodicity_error_scaled : float
        Largest |x_sim(T) - x(0)| over the periodic states of the open-loop run,
        each divided by its typical magnitude [-].
    periodicity_error_position_m : float
        |r_sim(T) - r(0)| in the periodic position components (y, z) [m].
    avg_p_mech_sim_w : float
        Average mechanical power of the open-loop run (trapezoid on the Radau
        points) [W].
    wall_time_s : float
    verdict : str
        ``"passed"`` when the interval defect is within
        :data:`optimize.analysis.result_check.MAX_DEFECT_SCALED`, else ``"failed: ..."``,
        also when the simulation could not finish (:func:`unfinished_simulation`). The
        open-loop figures carry no verdict: the kite is unstable open loop, so they
        measure the amplification of the defects as much as the defects.
    """

    scenario: str
    integrator: str
    interval_defect_position_m: float
    interval_defect_scaled: float
    open_loop_position_m: float
    periodicity_error_scaled: float
    periodicity_error_position_m: float
    avg_p_mech_sim_w: float
    wall_time_s: float
    verdict: str = "passed"


def _rel(fine: float, coarse: float) -> float:
    return abs(fine - coarse) / abs(coarse) if coarse else math.nan


def mesh_check(coarse: Ocp, fine: Ocp, scenario: Scenario, result: OcpResult) -> MeshCheck:
    """Re-solve ``scenario`` on ``fine`` (normally twice the intervals) and compare powers.

    Parameters
    ----------
    coarse : Ocp
        The OCP ``result`` was solved on.
    fine : Ocp
        The refined OCP (same model, more intervals).
    scenario : Scenario
    result : OcpResult
        The converged coarse solution.

    Returns
    -------
    MeshCheck
        If the interpolated start fails, a cold start (homotopy) on ``fine``
        is tried; its outcome is reported either way.
    """
    res = solve_interpolated(coarse, fine, scenario, result)
    route = "interpolated warm start"
    if not res.success:
        route = "cold start"
        res = solve_by_homotopy(fine, scenario)
    nan = math.nan
    return MeshCheck(
        scenario=scenario.name,
        n_intervals=coarse.n_intervals,
        n_intervals_fine=fine.n_intervals,
        status=res.status,
        success=res.success,
        iterations=res.iterations,
        wall_time_s=res.wall_time_s,
        route=route,
        avg_p_elec_w=result.avg_p_elec_w,
        avg_p_elec_fine_w=res.avg_p_elec_w if res.success else nan,
        avg_p_mech_w=result.avg_p_mech_w,
        avg_p_mech_fine_w=res.avg_p_mech_w if res.success else nan,
        period_s=result.period_s,
        period_fine_s=res.period_s if res.success else nan,
        rel_change_p_elec=_rel(res.avg_p_elec_w, result.avg_p_elec_w) if res.success else nan,
        rel_change_p_mech=_rel(res.avg_p_mech_w, result.avg_p_mech_w) if res.success else nan,
    )


def _interval_integrator(ocp: Ocp, period_s: float) -> ca.Function:
    x = ca.SX.sym("x", ocp.dae.states.size)
    u = ca.SX.sym("u", ocp.dae.controls.size)
    wind_speed_m_s = ca.SX.sym(WIND_SPEED)
    ode = ocp.dae.explicit_ode(x, u, wind_speed_m_s)
    h = period_s / ocp.n_intervals
    tgrid = [float(h * t) for t in ocp.coll.tau[1:]]
    return ca.integrator(
        "interval",
        "cvodes",
        {"x": x, "p": ca.vertcat(u, wind_speed_m_s), "ode": ode},
        0.0,
        tgrid,
        {"abstol": 1e-10, "reltol": 1e-10, "max_num_steps": 100000},
    )


def simulation_check(ocp: Ocp, result: OcpResult) -> SimulationCheck:
    """Integrate the optimal controls with CVODES and compare with the collocation states.

    Parameters
    ----------
    ocp : Ocp
        The OCP ``result`` was solved on.
    result : OcpResult
        A converged solution.
    """
    t0 = time.perf_counter()
    sol = ocp.unpack(result.warm.w)
    x_c, u = np.asarray(sol["x"]), np.asarray(sol["u"])
    n, d = ocp.n_intervals, ocp.coll.degree
    wind_speed_m_s = result.scenario.wind_speed_m_s
    step = _interval_integrator(ocp, sol["period_s"])
    scale = ocp.scales.state[:, None]
    states = ocp.dae.states
    pos, per_idx = states.indices(POSITION_STATES), states.indices(ocp.dae.periodic)
    defect_pos = defect_scaled = open_pos = 0.0
    x_open = x_c[:, 0]
    p_open = []
    for k in range(n):
        coll = x_c[:, k * d + 1 : (k + 1) * d + 1]
        par = np.append(u[:, k], wind_speed_m_s)
        local = np.asarray(step(x0=x_c[:, k * d], p=par)["xf"])
        defect_pos = max(
            defect_pos, float(np.max(np.linalg.norm(local[pos] - coll[pos], axis=0)))
        )
        defect_scaled = max(defect_scaled, float(np.max(np.abs(local - coll) / scale)))
        run = np.asarray(step(x0=x_open, p=par)["xf"])
        open_pos = max(open_pos, float(np.max(np.linalg.norm(run[pos] - coll[pos], axis=0))))
        x_open = run[:, -1]
        p_open.append(run)
    x_sim = np.hstack([x_c[:, :1], *p_open])
    u_pts = np.hstack([u[:, :1], np.repeat(u, d, axis=1)])  # control at every grid point
    z_sim = np.asarray(ocp.dae.solve_z.map(x_sim.shape[1])(x_sim, u_pts, wind_speed_m_s))
    p_mech = ocp.formulation.trajectory_outputs(x_sim, u_pts, z_sim, wind_speed_m_s)["p_mech_w"]
    t = grid_times(ocp, sol["period_s"])
    avg_p_mech = float(np.trapezoid(p_mech, t) / sol["period_s"])
    per = (x_open - x_c[:, 0])[per_idx] / ocp.scales.state[per_idx]
    yz = states.indices(("r_y_m", "r_z_m"))
    return SimulationCheck(
        scenario=result.scenario.name,
        integrator="cvodes (abstol = reltol = 1e-10), piecewise-constant controls",
        interval_defect_position_m=defect_pos,
        interval_defect_scaled=defect_scaled,
        open_loop_position_m=open_pos,
        periodicity_error_scaled=float(np.max(np.abs(per))),
        periodicity_error_position_m=float(np.linalg.norm(x_open[yz] - x_c[yz, 0])),
        avg_p_mech_sim_w=avg_p_mech,
        wall_time_s=time.perf_counter() - t0,
        verdict=("passed" if defect_scaled <= MAX_DEFECT_SCALED else
                 f"failed: interval defect {defect_scaled:.3g} state scales, above "
                 f"{MAX_DEFECT_SCALED}"),
    )


def unfinished_simulation(scenario: str, exc: Exception) -> SimulationCheck:
    """The finding of a simulation CVODES could not finish (``CV_TOO_MUCH_WORK`` ...)."""
    nan = math.nan
    why = str(exc).strip().splitlines()[-1][:200] if str(exc).strip() else type(exc).__name__
    return SimulationCheck(scenario, "cvodes", nan, nan, nan, nan, nan, nan, nan,
                           verdict=f"failed: the simulation could not finish ({why})")


# ------------------------------------------------------------------ running the checks
def run_mesh_task(task: tuple, progress: Any = None) -> MeshCheck:
    """Executor task: ``(name, problem, fine_problem, result)`` -> :class:`MeshCheck`.

    Builds (or takes from the per-process cache) the coarse and the fine OCP.
    """
    name, problem, fine_problem, result = task
    backend = OcpBackend()
    check = mesh_check(backend.build(problem), backend.build(fine_problem), result.scenario, result)
    if progress is not None:
        progress.put({"mesh": name})
    return dataclasses.replace(check, scenario=name)


def run_trust_checks(
    problem: Any, outcomes: Sequence[Any], wind_speeds_m_s: tuple[float, ...], handle: Any,
    show_progress: bool = True,
) -> dict:
    """Mesh check of each kind's middle-wind scenario (on the executor) and simulation
    check of every converged scenario (here).

    Parameters
    ----------
    problem : optimize.service.builder.Problem
        The sweep's problem.
    outcomes : sequence of optimize.service.outcome.ScenarioOutcome
    wind_speeds_m_s : tuple of float
        The wind grid [m/s]; the mesh check uses its middle speed.
    handle : optimize.service.executors.ExecutorHandle
    show_progress : bool
        Show the mesh checks' progress bar.

    Returns
    -------
    dict
        ``{"mesh": [MeshCheck as dict], "simulation": [SimulationCheck as dict],
        "lines": [str]}``.
    """
    from tqdm import tqdm

    fine = problem.refined()
    middle = wind_speeds_m_s[middle_index(wind_speeds_m_s)]
    picks = [o for o in outcomes if o.success and o.wind_speed_m_s == middle
             and fine is not None and o.result.warm.n_intervals == problem.n_intervals]
    bar = tqdm(total=len(picks), desc="mesh check", unit="solve", disable=not show_progress)
    futures = run_tasks(
        handle.executor,
        run_mesh_task,
        [(o.name, problem, fine, o.result) for o in picks],
        handle.channel,
        lambda event: bar.update(1),
    )
    bar.close()
    mesh, lines = [], []
    for o, fut in zip(picks, futures, strict=True):
        if fut.exception() is not None:
            lines.append(f"mesh check {o.name}: failed to run ({fut.exception()!r})")
            continue
        m = fut.result()
        mesh.append(dataclasses.asdict(m))
        lines.append(
            f"mesh check {m.scenario}: N={m.n_intervals} -> {m.n_intervals_fine}: "
            f"{m.status} ({m.route}, {m.iterations} it, {m.wall_time_s:.0f} s); "
            f"P_elec {m.avg_p_elec_w:.1f} -> {m.avg_p_elec_fine_w:.1f} W "
            f"({m.rel_change_p_elec:.2%}), P_mech {m.avg_p_mech_w:.1f} -> "
            f"{m.avg_p_mech_fine_w:.1f} W ({m.rel_change_p_mech:.2%})"
        )
    sims, sim_lines = simulation_checks(problem, outcomes)
    return {"mesh": mesh, "simulation": sims, "lines": lines + sim_lines}


def simulation_checks(problem: Any, outcomes: Sequence[Any]) -> tuple[list[dict], list[str]]:
    """Simulation check of every converged scenario (CVODES through each interval and open
    loop over the cycle), with the lines that summarize it.

    Parameters
    ----------
    problem : optimize.service.builder.Problem
        The sweep's problem.
    outcomes : sequence of optimize.service.outcome.ScenarioOutcome

    Returns
    -------
    sims : list of dict
        One SimulationCheck (as a dict) per converged scenario.
    lines : list of str
        The summary line and one line per scenario that did not pass.
    """
    builder, sims = OcpBackend(), []
    for o in outcomes:
        if o.success:  # on its own mesh (a retry may have refined it)
            ocp = builder.build(problem.with_intervals(o.result.warm.n_intervals))
            try:
                s = simulation_check(ocp, o.result)
            except RuntimeError as exc:  # CVODES gives up: CV_TOO_MUCH_WORK, CV_CONV_FAILURE
                s = unfinished_simulation(o.name, exc)
            sims.append(dataclasses.asdict(dataclasses.replace(s, scenario=o.name)))
    done = [s for s in sims if math.isfinite(s["interval_defect_scaled"])]
    if done:
        worst = max(done, key=lambda s: s["periodicity_error_scaled"])
        lines = [
            f"simulation check ({len(done)} cycles, CVODES): interval defect <= "
            f"{max(s['interval_defect_position_m'] for s in done):.2e} m, open loop <= "
            f"{max(s['open_loop_position_m'] for s in done):.2e} m, periodicity error <= "
            f"{worst['periodicity_error_scaled']:.2e} (scaled, {worst['scenario']}; the "
            "open-loop figures carry no verdict: the kite is unstable open loop)"
        ]
    else:
        lines = []
    lines += [f"simulation check {s['scenario']}: {s['verdict']}" for s in sims
              if s["verdict"] != "passed"]
    return sims, lines
