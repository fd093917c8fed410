"""The first solve of a problem: from the shipped initial guess when it fits, else by the
homotopy."""

from __future__ import annotations

import dataclasses
import logging

from optimize.problem.ocp import Ocp
from optimize.problem.scenario import Scenario
from optimize.solve.result import OcpResult
from optimize.solve.solve import solve
from optimize.solve.starts import stored_guess
from optimize.solve.starts.homotopy import cold_start

log = logging.getLogger(__name__)


def start(ocp: Ocp, scenario: Scenario) -> OcpResult:
    """Solve ``scenario`` with no neighbouring solution at hand.

    Warm-started from the shipped initial guess (:mod:`optimize.solve.starts.stored_guess`)
    when ``ocp.options.solver.stored_guess`` is set and the guess fits this OCP;
    otherwise, or when that solve fails, by the homotopy
    (:func:`optimize.solve.starts.homotopy.cold_start`). A failed stored-guess solve stays
    in ``stages`` and counts in the iterations and wall time.
    """
    guess, why = (stored_guess.load(ocp) if ocp.options.solver.stored_guess
                  else (None, "stored initial guess switched off"))
    log.info("%s: %s", scenario.name, why)
    if guess is None:
        return cold_start(ocp, scenario)
    res = solve(ocp, scenario, guess)
    stages = tuple({**s, "stage": f"stored-guess {s['stage']}"} for s in res.stages)
    if res.success:
        return dataclasses.replace(res, stages=stages, start="stored guess")
    log.info("%s: the solve from the stored initial guess ended %s; running the homotopy",
             scenario.name, res.status)
    hom = cold_start(ocp, scenario)
    return dataclasses.replace(
        hom, stages=stages + hom.stages, iterations=res.iterations + hom.iterations,
        wall_time_s=res.wall_time_s + hom.wall_time_s,
    )
