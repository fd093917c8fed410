"""Failed scenarios solved again from the other starts there are, before they are reported.

A scenario fails when no planned start converged to an optimum that passes the result
check (:mod:`optimize.analysis.result_check`: e.g. a collocation artifact that generates
more than the wind can give). Once its kind's grid is solved there are starts its own
solve did not have: :func:`retry_failed` tries, in order, the converged speeds of the same
kind (nearest first) and the other objective's optimum at the same wind speed (same drive
limits), and keeps the first that converges and passes. When none does and the scenario's
own optimum converged but was rejected, its mesh may be too coarse for the cycle
(the dynamics re-integrated between the collocation points leave it): that optimum is
interpolated onto twice the intervals and solved there, then on twice those
(:func:`retry_on_finer_mesh`); a result that passes stands on that mesh (the summary's
``n_intervals`` says which) and starts no solve of the sweep's own mesh. Every try is
an attempt of the scenario, so the summary's ``warm_source`` names the start that
succeeded.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

from optimize.kinds import OBJECTIVES
from optimize.problem.deadline import deadline
from optimize.problem.scenario import Scenario
from optimize.service.outcome import CRASH, Attempt, ScenarioOutcome, failure_status
from optimize.service.solves import spent_status

#: role of a retry in the progress events (:meth:`optimize.service.solves.Solves.attempt`)
RETRY = "retry"
#: converged speeds of the same kind tried per failed scenario (nearest first)
MAX_SAME_KIND = 2
#: finer meshes tried, each twice the intervals of the one before (the glider of
#: tests/test_retry_mesh.py at 14 x 3 passes its result check on 56 intervals)
MAX_REFINEMENTS = 2


def other_starts(solves: Any, scenario: Scenario, tried: set) -> list[Scenario]:
    """The starts to retry ``scenario`` from: up to :data:`MAX_SAME_KIND` converged speeds
    of its kind (nearest first), then the other objective's optimum at the same speed
    with the same drive limits; those in ``tried`` (names) left out."""
    same = [s for s in solves.nearest(scenario) if s.name not in tried][:MAX_SAME_KIND]
    other = [Scenario(scenario.wind_speed_m_s, o, scenario.drive_limits) for o in OBJECTIVES
             if o != scenario.objective]
    return same + [s for s in other if s in solves.converged(s.kind) and s.name not in tried]


def retry_failed(solves: Any, scenarios: Sequence[Scenario]) -> None:
    """Solve each failed one of ``scenarios`` again from :func:`other_starts` until one
    converges and passes its result check; the tries are added to its attempts either
    way (:meth:`optimize.service.solves.Solves.replace`).

    Parameters
    ----------
    solves : optimize.service.solves.Solves
        Has solved (or adopted) every one of ``scenarios``.
    scenarios : sequence of Scenario
        The grid scenarios to look at.
    """
    for scenario in scenarios:
        outcome = solves.outcomes.get(scenario)
        if outcome is None or outcome.success:
            continue
        tried = {a.source for a in outcome.attempts}
        for source in other_starts(solves, scenario, tried):
            attempt, result = solves.attempt(scenario, source, RETRY)
            outcome = dataclasses.replace(outcome, attempts=(*outcome.attempts, attempt),
                                          result=result)
            solves.replace(outcome, source)
            if attempt.success:
                break
        if not outcome.success:
            finer = retry_on_finer_mesh(solves, outcome)
            if finer is not outcome:
                solves.replace_remeshed(finer)


def retry_on_finer_mesh(solves: Any, outcome: ScenarioOutcome) -> ScenarioOutcome:
    """``outcome`` with its last result, when it converged (and its result check
    rejected it), interpolated onto twice the intervals and solved there
    (:meth:`optimize.service.builder.OcpBackend.remesh`) and checked on that mesh; again
    from that result on twice those, up to :data:`MAX_REFINEMENTS` meshes, until one
    passes. Each is an attempt whose source names the scenario and the mesh. ``outcome``
    itself when its last result did not converge or the backend has no other mesh."""
    coarse, ocp = solves.problem, None
    for _ in range(MAX_REFINEMENTS):
        result = outcome.result
        if (outcome.success or result is None or not getattr(result, "success", False)
                or not hasattr(solves.backend, "remesh")):
            break
        fine = coarse.refined()
        if fine is None:
            break
        attempt, res, ocp = _remesh_attempt(solves, outcome, ocp or solves.ocp, fine)
        outcome = dataclasses.replace(outcome, attempts=(*outcome.attempts, attempt),
                                      result=res if res is not None else result)
        coarse = fine
    return outcome


def _remesh_attempt(solves: Any, outcome: ScenarioOutcome, coarse_ocp: Any, fine: Any
                    ) -> tuple[Attempt, Any, Any]:
    """One solve of ``outcome``'s scenario on the ``fine`` problem from its last result
    (on ``coarse_ocp``), within what is left of the scenario's budget (not run when nothing
    is: :func:`~optimize.service.solves.spent_status`): the attempt, its result (None if it
    raised or did not run) and the fine OCP."""
    source = f"{outcome.name} on {fine.n_intervals} intervals"
    solves.tell("start", outcome.name, RETRY, source, "")
    with solves.budget(outcome.scenario) as left_s:
        attempt, res, fine_ocp = (
            _remesh_run(solves, outcome, coarse_ocp, fine, source, left_s) if left_s > 0
            else (Attempt(source, spent_status(solves.problem.scenario_budget_s), False, 0,
                          0.0), None, None))
    solves.count(attempt, RETRY)
    solves.tell("done", outcome.name, RETRY, source, attempt.status)
    return attempt, res, fine_ocp


def _remesh_run(solves: Any, outcome: ScenarioOutcome, coarse_ocp: Any, fine: Any,
                source: str, left_s: float) -> tuple[Attempt, Any, Any]:
    """:func:`_remesh_attempt`'s solver run, its calls within ``left_s`` [s], and its
    check."""
    t0, fine_ocp = time.perf_counter(), None
    try:
        fine_ocp = solves.backend.build(fine)
        with deadline(left_s):
            res = solves.backend.remesh(coarse_ocp, fine_ocp, outcome.scenario, outcome.result)
    except Exception as exc:  # noqa: BLE001 - a crash is this attempt's failure, reported
        return (Attempt(source, failure_status(CRASH, exc), False, 0, time.perf_counter() - t0),
                None, fine_ocp)
    check = solves.backend.check(fine_ocp, res, outcome.name) if res.success else None
    return Attempt(source, str(res.status), bool(res.success) and (
        check is None or check.passed), int(res.iterations), float(res.wall_time_s),
        check), res, fine_ocp
