"""The first solve of a problem: from the shipped initial guess when it fits, else by the
homotopy on a coarse mesh, carried to the problem's own."""

from __future__ import annotations

import dataclasses
import logging

from optimize.problem.ocp import Ocp, on_mesh
from optimize.problem.scenario import Scenario
from optimize.solve.result import OcpResult
from optimize.solve.solve import solve
from optimize.solve.starts import stored_guess
from optimize.solve.starts.homotopy import cold_start
from optimize.solve.starts.remesh import solve_interpolated

log = logging.getLogger(__name__)

#: collocation intervals of the homotopy's coarse mesh. On the shipped AP2 file (40 x 4)
#: the homotopy on 10 intervals and the solve carried onto 40 took 95-101 iterations at
#: 8 and 9 m/s (the homotopy on 40: 87-103) in 3.6-8.7 s of CPU instead of 11.9-17.6 s
#: (benchmarks/README.md, foreign kites)
COARSE_INTERVALS = 10


def start(ocp: Ocp, scenario: Scenario) -> OcpResult:
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
    """The homotopy (:func:`optimize.solve.starts.homotopy.cold_start`) on
    :data:`COARSE_INTERVALS` intervals of the OCP's degree, its optimum carried onto the
    OCP's mesh and solved there (:func:`optimize.solve.starts.remesh.solve_interpolated`);
    on the OCP's own mesh when that has fewer than twice as many intervals, or when the
    coarse way fails (its solves then stay in ``stages``). Every stage counts in the
    iterations; those on the coarse mesh are named ``coarse <stage>``."""
    if ocp.n_intervals < 2 * COARSE_INTERVALS:
        return cold_start(ocp, scenario)
    coarse = on_mesh(ocp, COARSE_INTERVALS, ocp.coll.degree)
    first = cold_start(coarse, scenario)
    stages = tuple({**s, "stage": f"coarse {s['stage']}"} for s in first.stages)
    status = first.status
    if first.success:
        fine = solve_interpolated(coarse, ocp, scenario, first)
        if fine.success:
            return _after(dataclasses.replace(fine, start="homotopy"), stages)
        stages, status = stages + fine.stages, f"on {ocp.n_intervals} intervals {fine.status}"
    log.info("%s: the homotopy on %d intervals ended %s; running it on %d", scenario.name,
             COARSE_INTERVALS, status, ocp.n_intervals)
    return _after(cold_start(ocp, scenario), stages)


def _after(result: OcpResult, stages: tuple[dict, ...]) -> OcpResult:
    """``result`` with ``stages`` (of the solves before it) ahead of its own, their
    iterations and wall time added."""
    return dataclasses.replace(
        result, stages=stages + result.stages,
        iterations=sum(int(s["iterations"]) for s in stages) + result.iterations,
        wall_time_s=sum(float(s["wall_time_s"]) for s in stages) + result.wall_time_s)
