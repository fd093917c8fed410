"""Period scan: a converged scenario solved again with its period held elsewhere, then
freed; the better optimum kept.

A pumping cycle's objective is flat along the period and has several optima there. The
shipped AP2 file at 10 m/s mech-free: the cold start lands on 4.81 kW at 33.5 s; held
at 45 or 60 s and then freed, the same file gives 5.06 and 5.07 kW at 64 s
(benchmarks/README.md, AP2's local optima). The local-optimum check
(:mod:`optimize.service.local_optima`) compares neighbouring wind speeds: it cannot
check a kind of fewer than :data:`optimize.sweep_folder.MIN_CURVE_SPEEDS` speeds, nor
see a whole kind on one branch. The scan looks along the period instead
(:func:`scan_periods`): for each held period (:func:`held_periods`), a warm solve from
the scenario's optimum with the period held, then a warm solve from that with the
period free; the best optimum, if better by more than
:func:`optimize.service.local_optima.better_margin_w`, replaces the result. Every run
is recorded in the outcome's ``resolves`` (summary ``resolved_from``, the log's and the
report's local-optimum lines).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

from optimize.problem.scenario import Scenario
from optimize.service.foreign import HeldStart
from optimize.service.local_optima import better_margin_w, objective_power_w
from optimize.service.outcome import Resolve

#: the role of the scan's solver runs in the progress events (:meth:`Solves.attempt`)
PERIOD_SCAN = "period scan"
#: the held periods span this factor each way from the optimum's own (within the bounds)
SCAN_SPAN = 2.0
#: a held period within this fraction of the optimum's own is not tried (the same start)
SCAN_GAP = 0.15


def held_periods(period_s: float, bounds_s: tuple[float, float], n: int) -> list[float]:
    """The periods [s] the scan holds a scenario of period ``period_s`` at.

    Parameters
    ----------
    period_s : float
        The optimum's period [s].
    bounds_s : (float, float)
        Bounds of the free period [s].
    n : int
        Periods asked for: ``period_s * SCAN_SPAN**(k/m)`` for ``k = 1, -1, 2, -2, ...``
        (``m = ceil(n/2)``, so the last pair is ``SCAN_SPAN`` times and ``1/SCAN_SPAN``
        times the optimum's), the first ``n`` of them.

    Returns
    -------
    list of float
        Those periods to 3 significant digits, clipped into the bounds, without repeats
        and without those within :data:`SCAN_GAP` of ``period_s`` (fewer than ``n``
        where the bounds cut them).
    """
    m = math.ceil(n / 2)
    factors = [SCAN_SPAN ** (s * k / m) for k in range(1, m + 1) for s in (1, -1)][:n]
    lo, hi = bounds_s
    out: list[float] = []
    for f in factors:
        p = min(max(float(f"{period_s * f:.3g}"), lo), hi)
        if abs(p - period_s) > SCAN_GAP * period_s and p not in out:
            out.append(p)
    return out


def _held_run(solves: Any, scenario: Scenario, period_s: float
              ) -> tuple[Any, Any, HeldStart | None]:
    """Hold ``scenario``'s period at ``period_s`` from its own optimum, then free it: the
    last attempt (named after the held start), its result and the held start (None when
    the held solve failed)."""
    held_attempt, held = solves.attempt(scenario, scenario, PERIOD_SCAN, period_s=period_s)
    depth = solves.outcomes[scenario].depth
    start = HeldStart(scenario, "held", depth + 1, warm=getattr(held, "warm", None),
                      period_s=period_s)
    if not held_attempt.success:
        return dataclasses.replace(held_attempt, source=start.name), None, None
    attempt, result = solves.attempt(scenario, start, PERIOD_SCAN)
    return attempt, result, start


def scan_periods(solves: Any, scenarios: Sequence[Scenario], n: int) -> None:
    """Scan the period of each converged one of ``scenarios`` (see the module docstring).

    Parameters
    ----------
    solves : optimize.service.solves.Solves
        Has solved every one of ``scenarios``; a kept optimum replaces the scenario's
        outcome, record and warm start there (:meth:`Solves.replace`).
    scenarios : sequence of Scenario
    n : int
        Held periods per scenario (:func:`held_periods`); 0 scans nothing.
    """
    if n <= 0:
        return
    bounds = solves.backend.period_bounds(solves.ocp)
    for scenario in scenarios:
        o = solves.outcomes.get(scenario)
        if o is not None and o.success and getattr(o.result, "period_s", None) is not None:
            _scan_one(solves, scenario, held_periods(float(o.result.period_s), bounds, n))


def _scan_one(solves: Any, scenario: Scenario, periods: list[float]) -> None:
    """Hold ``scenario``'s period at each of ``periods`` and free it; record every run and
    keep the best optimum when it is better than the first by the local-optimum margin."""
    o, kind = solves.outcomes[scenario], scenario.kind
    before = objective_power_w(kind, o.result)
    runs = [(p, *_held_run(solves, scenario, p)) for p in periods]
    found = [objective_power_w(kind, result) if attempt.success else math.nan
             for _, attempt, result, _ in runs]
    best = min((i for i, run in enumerate(runs) if run[1].success), key=found.__getitem__,
               default=None)
    keep = best is not None and found[best] < before - better_margin_w(before)
    o = dataclasses.replace(o, resolves=(*o.resolves, *(
        Resolve(attempt, f, before, keep and i == best, p)
        for i, ((p, attempt, _, _), f) in enumerate(zip(runs, found, strict=True)))))
    if not keep:
        solves.outcomes[scenario] = o
        return
    _, attempt, result, start = runs[best]
    solves.replace(dataclasses.replace(o, attempts=(*o.attempts, attempt), result=result), start)
