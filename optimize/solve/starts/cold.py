"""The first solve of a problem: from the shipped initial guess when it fits, else by the
homotopy on a coarse mesh, carried to the problem's own."""

from __future__ import annotations

import dataclasses
import logging
import math

from optimize.problem.deadline import COLD_START_CALLS, deadline
from optimize.problem.ocp import Ocp, on_mesh
from optimize.problem.options import MIN_COLLOCATION_POINTS
from optimize.problem.scenario import Scenario
from optimize.solve.result import OcpResult
from optimize.solve.solve import solve
from optimize.solve.starts import stored_guess
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.solve.starts.remesh import solve_interpolated

log = logging.getLogger(__name__)

#: collocation points of the homotopy's coarse mesh, over the fewest the result check
#: trusts (:data:`optimize.problem.options.MIN_COLLOCATION_POINTS`): 13 intervals of
#: degree 4. On the shipped AP2 file (40 x 4) the homotopy there and the solve carried
#: onto 40 took 96, 104 and 129 iterations at 8 (mech-free), 9 (elec-lim) and 12 m/s
#: (mech-free), in 5.3-11.7 s of CPU; on 40 intervals directly 87, 103 and 116 in
#: 11.9-17.6 s; on 10 intervals 95, 101 and 166 (benchmarks/README.md, foreign kites)
COARSE_POINTS_FACTOR = 1.25


def coarse_intervals(degree: int) -> int:
    """Intervals of the homotopy's coarse mesh of ``degree`` (:data:`COARSE_POINTS_FACTOR`)."""
    return math.ceil(COARSE_POINTS_FACTOR * MIN_COLLOCATION_POINTS / degree)


def start(ocp: Ocp, scenario: Scenario) -> OcpResult:
    """:func:`_start` within :data:`~optimize.problem.deadline.COLD_START_CALLS` times a
    solver call's limit (``call_time_limit_s``; its solver calls past them are not made:
    the start fails with the status :data:`~optimize.problem.deadline.WALL_STATUS`)."""
    with deadline(COLD_START_CALLS * ocp.options.solver.call_time_limit_s):
        return _start(ocp, scenario)


def _start(ocp: Ocp, scenario: Scenario) -> OcpResult:
    """Solve ``scenario`` with no neighbouring solution at hand.

    Warm-started from the shipped initial guess (:mod:`optimize.solve.starts.stored_guess`),
    or the start file of ``ocp.options.solver.start_file`` (a sweep's ``start.npz``),
    when ``ocp.options.solver.stored_guess`` is set and it fits this OCP;
    otherwise, or when that solve fails, by the homotopy (:func:`homotopy_start`). A
    failed stored-guess solve stays in ``stages`` and counts in the iterations and wall
    time.
    """
    o = ocp.options.solver
    guess, why = (stored_guess.load(ocp, o.start_file or stored_guess.GUESS_PATH)
                  if o.stored_guess else (None, "stored initial guess switched off"))
    log.info("%s: %s", scenario.name, why)
    if guess is None:
        return homotopy_start(ocp, scenario)
    res = solve(ocp, scenario, guess)
    stages = tuple({**s, "stage": f"stored-guess {s['stage']}"} for s in res.stages)
    if res.success:
        return dataclasses.replace(res, stages=stages, start="stored guess")
    log.info("%s: the solve from the stored initial guess ended %s; running the homotopy",
             scenario.name, res.status)
    return _after(homotopy_start(ocp, scenario), stages)


def homotopy_start(ocp: Ocp, scenario: Scenario) -> OcpResult:
    """The homotopy (:func:`optimize.solve.starts.homotopy.solve_by_homotopy`) on the coarse
    mesh of the OCP's degree (:func:`coarse_intervals`), its optimum carried onto the
    OCP's mesh and solved there (:func:`optimize.solve.starts.remesh.solve_interpolated`);
    on the OCP's own mesh when that has fewer than twice as many intervals, or when the
    coarse way fails (its solves then stay in ``stages``). Every stage counts in the
    iterations; those on the coarse mesh are named ``coarse <stage>``."""
    n_coarse = coarse_intervals(ocp.coll.degree)
    if ocp.n_intervals < 2 * n_coarse:
        return solve_by_homotopy(ocp, scenario)
    coarse = on_mesh(ocp, n_coarse, ocp.coll.degree)
    first = solve_by_homotopy(coarse, scenario)
    stages = tuple({**s, "stage": f"coarse {s['stage']}"} for s in first.stages)
    status = first.status
    if first.success:
        fine = solve_interpolated(coarse, ocp, scenario, first)
        if fine.success:
            return _after(dataclasses.replace(fine, start="homotopy"), stages)
        stages, status = stages + fine.stages, f"on {ocp.n_intervals} intervals {fine.status}"
    log.info("%s: the homotopy on %d intervals ended %s; running it on %d", scenario.name,
             n_coarse, status, ocp.n_intervals)
    return _after(solve_by_homotopy(ocp, scenario), stages)


def _after(result: OcpResult, stages: tuple[dict, ...]) -> OcpResult:
    """``result`` with ``stages`` (of the solves before it) ahead of its own, their
    iterations and wall time added."""
    return dataclasses.replace(
        result, stages=stages + result.stages,
        iterations=sum(int(s["iterations"]) for s in stages) + result.iterations,
        wall_time_s=sum(float(s["wall_time_s"]) for s in stages) + result.wall_time_s)
