"""Initialization without a stored solution: the homotopy of issue 4.

Stages (each one IPOPT call, logged with status, iterations and wall time):

1. ``track``: follow the circular-loop guess at its fixed period, with free
   fictitious forces and moments initialised to the guess's exact residual
   (so the dynamics hold at the start), lightly penalized.
2. ``penalize-1``, ``penalize-10``, ``penalize-100``: the same with the
   fictitious forces penalized with a rising weight (warm starts). The issue's
   prototype went 1 then 100; the intermediate 10 cut the total iterations
   at N = 40 from 198 to 173 (mechanical) and 206 to 181 (electrical).
3. ``power``: fictitious forces fixed at zero, period free, the scenario's
   power objective and drive limits.

A stage that fixes the fictitious forces at zero while still tracking is
deliberately absent (it stalled for 400 s in the issue's prototype).
"""

from __future__ import annotations

import logging

import numpy as np

from optimize.problem.guess import LoopGuess, circular_loop
from optimize.problem.ocp import Ocp, RawSolve, grid_times
from optimize.problem.scenario import Scenario
from optimize.solve.result import OcpResult, make_result

log = logging.getLogger(__name__)

#: light penalty of stage 1 (keeps the fictitious forces bounded) and the rising weights
TRACK_FICT_WEIGHT = 1e-3
PENALTY_WEIGHTS = (1.0, 10.0, 100.0)
#: warm-start bound push of the penalty stages: each stage only reweights the previous
#: one (same bounds, same active set), so its point stays where it was. With the
#: scenario warm solves' 1e-2 the mech-lim-7.0 homotopy ended in a local optimum
#: 0.36 W worse (benchmarks/README.md)
HOMOTOPY_BOUND_PUSH = 1e-9


def _record(stages: list[dict], name: str, raw: RawSolve, scenario: Scenario) -> None:
    stages.append({"stage": name, "status": raw.status, "success": raw.success,
                   "iterations": raw.iterations, "wall_time_s": raw.wall_time_s,
                   "cpu_time_s": raw.cpu_time_s})
    log.info("%s homotopy %-12s %-22s %4d it %6.1f s (cpu %.1f s)", scenario.name, name,
             raw.status, raw.iterations, raw.wall_time_s, raw.cpu_time_s)


def power_weights(scenario: Scenario) -> dict[str, float]:
    """Objective weights of the scenario (minimize average power drawn, i.e. maximize output)."""
    elec = scenario.objective == "electrical"
    return {"w_elec": 1.0 if elec else 0.0, "w_mech": 0.0 if elec else 1.0}


def cold_start(ocp: Ocp, scenario: Scenario, guess: LoopGuess | None = None) -> OcpResult:
    """Solve ``scenario`` from the circular-loop guess through the homotopy.

    Parameters
    ----------
    ocp : Ocp
        Built by :func:`optimize.problem.ocp.build_ocp`.
    scenario : Scenario
        Wind speed, objective and drive limits of the final stage.
    guess : LoopGuess, optional
        Geometry of the initial loop; the default suits 5 to 10 m/s.

    Returns
    -------
    OcpResult
        Result of the final (power) stage; ``stages`` lists every stage and
        ``iterations``/``wall_time_s`` are the totals.
    """
    guess = guess or LoopGuess()
    wind = scenario.wind_speed_m_s
    lay = ocp.layout
    x, z, fict = circular_loop(ocp.dae, guess, grid_times(ocp, guess.period_s), wind)
    u = np.zeros((lay.i_u.shape[0], ocp.options.n_intervals))
    w0 = ocp.pack(x, z[:, 1:], u, fict[:, 1:], guess.period_s)
    stages: list[dict] = []

    track_bounds = ocp.bounds(drive_limits=False, fix_fictitious=False, period_s=guess.period_s)
    p = ocp.params(wind, w_track=1.0, w_fict=TRACK_FICT_WEIGHT, x_ref=x)
    raw = ocp.run(w0, p, track_bounds, warm=False)
    _record(stages, "track", raw, scenario)
    for weight in PENALTY_WEIGHTS:
        p = ocp.params(wind, w_track=1.0, w_fict=weight, x_ref=x)
        raw = ocp.run(raw.w, p, track_bounds, warm=True, lam_x0=raw.lam_x, lam_g0=raw.lam_g,
                      bound_push=HOMOTOPY_BOUND_PUSH)
        _record(stages, f"penalize-{weight:g}", raw, scenario)

    bounds = ocp.bounds(drive_limits=scenario.drive_limits, fix_fictitious=True, period_s=None)
    p = ocp.params(wind, **power_weights(scenario))
    raw = ocp.run(raw.w, p, bounds, warm=False)
    _record(stages, "power", raw, scenario)
    return make_result(ocp, scenario, raw, p, bounds, stages, start="homotopy")
