"""Failed scenarios solved again from the other starts there are, before they are reported.

A scenario fails when no planned start converged to an optimum that passes the result
check (:mod:`optimize.analysis.result_check`: e.g. a collocation artifact that generates
more than the wind can give). Once its kind's grid is solved there are starts its own
solve did not have: :func:`retry_failed` tries, in order, the converged speeds of the same
kind (nearest first) and the other objective's optimum at the same wind speed (same drive
limits), and keeps the first that converges and passes; every try is an attempt of the
scenario, so the summary's ``warm_source`` names the start that succeeded.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from optimize.kinds import KINDS
from optimize.problem.scenario import scenario_name

#: role of a retry in the progress events (:meth:`optimize.service.solver.Solver.attempt`)
RETRY = "retry"
#: converged speeds of the same kind tried per failed scenario (nearest first)
MAX_SAME_KIND = 2


def other_starts(solver: Any, kind: str, wind_speed_m_s: float,
                 tried: set) -> list[tuple[str, float]]:
    """The starts to retry ``kind`` at ``wind_speed_m_s`` [m/s] from: up to :data:`MAX_SAME_KIND`
    converged speeds of the kind (nearest first), then the other objective's optimum at
    the same speed with the same drive limits; those in ``tried`` (names) left out."""
    near = sorted(solver.converged(kind), key=lambda w: abs(w - wind_speed_m_s))
    same = [(kind, w) for w in near if scenario_name(kind, w) not in tried][:MAX_SAME_KIND]
    mine = KINDS[kind]
    other = [(k, wind_speed_m_s) for k, v in KINDS.items()
             if v.objective != mine.objective and v.drive_limits == mine.drive_limits
             and wind_speed_m_s in solver.converged(k)
             and scenario_name(k, wind_speed_m_s) not in tried]
    return same + other


def retry_failed(solver: Any, keys: Sequence[tuple[str, float]]) -> None:
    """Solve each failed scenario of ``keys`` again from :func:`other_starts` until one
    converges and passes its result check; the tries are added to its attempts either
    way (:meth:`optimize.service.solver.Solver.replace`).

    Parameters
    ----------
    solver : optimize.service.solver.Solver
        Has solved (or adopted) every ``(kind, wind_speed_m_s)`` of ``keys``.
    keys : sequence of (kind, wind_speed_m_s)
        The grid scenarios to look at.
    """
    for k in keys:
        outcome = solver.outcomes.get(k)
        if outcome is None or outcome.success:
            continue
        tried = {a.source for a in outcome.attempts}
        for source in other_starts(solver, *k, tried):
            attempt, result = solver.attempt(*k, source, RETRY)
            outcome = dataclasses.replace(outcome, attempts=(*outcome.attempts, attempt),
                                          result=result)
            solver.replace(outcome, source)
            if attempt.success:
                break
