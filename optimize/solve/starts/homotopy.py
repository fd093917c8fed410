"""Initialization without a stored solution: a homotopy from a circular loop.

Stages (each one IPOPT call, logged with status, iterations and wall time):

1. ``track``: follow the circular-loop guess (period free), with free
   fictitious forces and moments initialised to the guess's exact residual
   (so the dynamics hold at the start), lightly penalized.
2. ``penalize-1``, ``penalize-10``, ``penalize-100``: the same with the
   fictitious forces penalized with a rising weight (warm starts). Going 1
   then 100 takes more iterations than with the intermediate 10
   (benchmarks/README.md).
3. ``power-penalized``: the scenario's power objective and drive limits in place of
   the tracking, the fictitious forces still free at the last penalty weight (a warm
   start: the same variables and bounds, only the objective moves).
4. ``power``: fictitious forces fixed at zero, period free (a warm start).

Every stage but the last is only the start of the next: it ends on IPOPT's central
path at the barrier parameter :data:`HOMOTOPY_BARRIER`, solved to that tolerance, and
the next warm-starts at the same barrier (:class:`optimize.solve.nlp_solver.Setting`),
instead of each stage descending to an optimum and the next climbing back. The
last-but-one stage changes the objective with the fictitious forces still free, so
fixing them is a small step. On the shipped AP2 file (N = 40) the cold starts at 8, 9
and 12 m/s took 83-130 iterations this way, against 157-237 with every stage solved
to the tolerance and a cold ``power`` stage from the tracked loop
(benchmarks/README.md, foreign kites).

A stage that fixes the fictitious forces at zero while still tracking is
deliberately absent: it stalls.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from optimize.problem.ocp import Ocp
from optimize.problem.scenario import Scenario
from optimize.solve.nlp_solver import RawSolve, Setting, run
from optimize.solve.result import OcpResult, make_result
from optimize.solve.starts.fill import part_start

log = logging.getLogger(__name__)

#: light penalty of stage 1 (keeps the fictitious forces bounded) and the rising weights
TRACK_FICT_WEIGHT = 1e-3
PENALTY_WEIGHTS = (1.0, 10.0, 100.0)
#: warm-start bound push of the penalty stages: each stage only reweights the previous
#: one (same bounds, same active set), so its point stays where it was. With the
#: scenario warm solves' 1e-2 the mech-lim-7.0 homotopy ended in a local optimum
#: 0.36 W worse (benchmarks/README.md)
HOMOTOPY_BOUND_PUSH = 1e-9
#: intermediate penalty weights tried, in all, when penalty stages fail
MAX_INSERTED = 4
#: the barrier parameter every stage but the last ends at (its central path point is
#: the next stage's warm start)
HOMOTOPY_BARRIER = Setting(mu_init=1e-3, mu_target=1e-3)
#: warm-start bound push of the power stages, whose active set moves from the tracked
#: loop's to the cycle's
POWER_BOUND_PUSH = 1e-3
#: the power stage starts only once the RMS of the scaled fictitious forces is below this
FICT_RMS_MAX = 0.05
#: the largest penalty weight tried to get there
MAX_PENALTY_WEIGHT = 1e4


def _record(stages: list[dict], name: str, raw: RawSolve, label: str) -> None:
    """Add the solver call ``raw`` as the stage ``name`` to ``stages``, and log it under
    ``label`` (the scenario's name)."""
    stages.append(raw.stage(name))
    log.info("%s homotopy %-12s %-22s %4d it %6.1f s (cpu %.1f s)", label, name,
             raw.status, raw.iterations, raw.wall_time_s, raw.cpu_time_s)


def _failed(ocp: Ocp, scenario: Scenario, raw: RawSolve, p: np.ndarray, bounds: tuple,
            stages: list[dict], stage: str) -> OcpResult:
    """A homotopy that stopped at ``stage``: a failed result naming the stage."""
    res = make_result(ocp, scenario, raw, p, bounds, stages, start="homotopy")
    return dataclasses.replace(res, success=False,
                               status=f"homotopy stage {stage}: {raw.status}")


def fictitious_rms(ocp: Ocp, w_scaled: np.ndarray) -> float:
    """Root mean square of the scaled fictitious forces and moments [-]."""
    return float(np.sqrt(np.mean(np.asarray(w_scaled)[ocp.layout.i_f] ** 2)))


def solve_by_homotopy(ocp: Ocp, scenario: Scenario) -> OcpResult:
    """Solve ``scenario`` from the parts' own start (the kite's circular loop,
    :func:`optimize.solve.starts.fill.part_start`) through the homotopy.

    Stages: ``track`` (period free), ``penalize-W`` for the weights of
    :data:`PENALTY_WEIGHTS`; when a penalty stage fails, intermediate weights
    (geometric means with the last good weight, at most :data:`MAX_INSERTED`)
    are tried from the last good point; further weights (x10, up to
    :data:`MAX_PENALTY_WEIGHT`) follow while the scaled fictitious forces' RMS
    exceeds :data:`FICT_RMS_MAX`; then ``power-penalized`` and ``power``. A stage that still fails,
    or fictitious forces that stay large, end the homotopy: the result is a
    failed solve whose status names the stage.

    Parameters
    ----------
    ocp : Ocp
        Built by :func:`optimize.problem.ocp.build_ocp`.
    scenario : Scenario
        Wind speed, objective and drive limits of the final stage.

    Returns
    -------
    OcpResult
        Result of the final (power) stage; ``stages`` lists every stage and
        ``iterations``/``wall_time_s`` are the totals.
    """
    parameters, period = scenario.parameters, ocp.loop.period_s
    guess = part_start(ocp, period, parameters)
    x = guess["x"]
    w0 = ocp.pack(x, guess["z"], guess["u"], guess["fict"], period)
    stages: list[dict] = []

    track_bounds = ocp.bounds(drive_limits=False, fix_fictitious=False, period_s=None)
    p = ocp.params(parameters, w_track=1.0, w_fict=TRACK_FICT_WEIGHT, x_ref=x)
    raw = run(ocp, w0, p, track_bounds, warm=False,
              setting=Setting(mu_target=HOMOTOPY_BARRIER.mu_target))
    _record(stages, "track", raw, scenario.name)
    if not raw.success:
        return _failed(ocp, scenario, raw, p, track_bounds, stages, "track")

    def penalize(start: RawSolve, weight: float) -> tuple[RawSolve, np.ndarray]:
        p_w = ocp.params(parameters, w_track=1.0, w_fict=weight, x_ref=x)
        out = run(ocp, start.w, p_w, track_bounds, warm=True, lam_x0=start.lam_x,
                  lam_g0=start.lam_g, bound_push=HOMOTOPY_BOUND_PUSH, setting=HOMOTOPY_BARRIER)
        _record(stages, f"penalize-{weight:g}", out, scenario.name)
        return out, p_w

    weights = list(PENALTY_WEIGHTS)
    last_weight, inserted = TRACK_FICT_WEIGHT, 0
    while weights:
        weight = weights.pop(0)
        trial, p = penalize(raw, weight)
        if trial.success:
            raw, last_weight = trial, weight
        elif inserted < MAX_INSERTED:
            inserted += 1
            weights[:0] = [float(np.sqrt(last_weight * weight)), weight]
            continue
        else:
            return _failed(ocp, scenario, trial, p, track_bounds, stages, f"penalize-{weight:g}")
        if not weights and fictitious_rms(ocp, raw.w) > FICT_RMS_MAX:
            if weight * 10 > MAX_PENALTY_WEIGHT:
                raw = dataclasses.replace(
                    raw, status=f"fictitious forces RMS {fictitious_rms(ocp, raw.w):.2g} "
                    f"> {FICT_RMS_MAX:g} of their scale")
                return _failed(ocp, scenario, raw, p, track_bounds, stages,
                               f"penalize-{weight:g}")
            weights.append(weight * 10)

    return _power(ocp, scenario, raw, last_weight, stages)


def _power(ocp: Ocp, scenario: Scenario, raw: RawSolve, weight: float, stages: list[dict]
           ) -> OcpResult:
    """The homotopy's power stages from the penalized tracking point ``raw``: the power
    objective with the fictitious forces still free at ``weight`` (``power-penalized``),
    then fixed at zero (``power``)."""
    free = ocp.bounds(drive_limits=scenario.drive_limits, fix_fictitious=False, period_s=None)
    p = ocp.params(scenario.parameters, scenario.weights, w_fict=weight)
    raw = run(ocp, raw.w, p, free, warm=True, lam_x0=raw.lam_x, lam_g0=raw.lam_g,
              bound_push=POWER_BOUND_PUSH, setting=HOMOTOPY_BARRIER)
    _record(stages, "power-penalized", raw, scenario.name)
    if not raw.success:
        return _failed(ocp, scenario, raw, p, free, stages, "power-penalized")
    bounds = ocp.bounds(drive_limits=scenario.drive_limits, fix_fictitious=True, period_s=None)
    p = ocp.params(scenario.parameters, scenario.weights)
    raw = run(ocp, raw.w, p, bounds, warm=True, lam_x0=raw.lam_x, lam_g0=raw.lam_g,
              bound_push=POWER_BOUND_PUSH, setting=Setting(mu_init=HOMOTOPY_BARRIER.mu_init))
    _record(stages, "power", raw, scenario.name)
    if not raw.success:
        return _failed(ocp, scenario, raw, p, bounds, stages, "power")
    return make_result(ocp, scenario, raw, p, bounds, stages, start="homotopy")
