"""Local optima: a scenario off its kind's smooth curve is solved again from its neighbours.

A cold start or a chain can land on a local optimum: one wind speed of a kind then
disagrees with the curve through its neighbours (a jump in average power or
period, :func:`off_curve`). :func:`resolve_local_optima` solves each such
scenario again, warm-started from each converged neighbouring wind speed of its
kind other than the one its result came from, and keeps the better optimum, which
is then carried along the kind while it keeps improving its neighbours.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from optimize.kinds import KINDS
from optimize.problem.scenario import Scenario
from optimize.service.outcome import Resolve
from optimize.sweep_folder import MIN_CURVE_SPEEDS

#: a scenario whose objective power departs from the smooth curve through its
#: neighbours of the same kind by more than this fraction of the kind's largest |power|,
#: or whose period departs by more than :data:`JUMP_PERIOD_RTOL` of its own, is re-solved
#: from its neighbours. On the paper's 20 optima (4:10:1.5) the interior points depart
#: by at most 0.02 and 0.14 (where a drive limit starts to bind); the local optima
#: that led here were 0.05 of the power
JUMP_POWER_RTOL = 0.03
JUMP_PERIOD_RTOL = 0.15
#: neighbours on each side of the smooth curve's local fit
CURVE_NEIGHBOURS = 2
#: rounds of detection and re-solve per kind (a kept re-solve can reveal the next one)
MAX_RESOLVE_ROUNDS = 6


#: the role of a re-solve in the progress events (:meth:`Solves.attempt`)
LOCAL_OPTIMUM = "local optimum"


def objective_power_w(kind: str, result: Any) -> float:
    """Average power [W] the kind's objective maximizes (negative = generated); NaN if absent."""
    value = getattr(result, KINDS[kind].summary_column, math.nan)
    return float(value) if value is not None else math.nan


def better_margin_w(power_w: float) -> float:
    """How much lower [W] a re-solve's objective power must be to count as a better
    optimum: 0.05 W or 1e-4 of the power, whichever is larger (solver tolerance)."""
    return max(0.05, 1e-4 * abs(power_w))


def _curve_prediction(wind_speeds_m_s: list[float], values: list[float], i: int) -> float:
    """``values[i]`` predicted from its nearest neighbours by a local polynomial; NaN
    with fewer than two.

    Inside the grid: the least-squares quadratic through up to :data:`CURVE_NEIGHBOURS`
    points on each side (exact for a cubic on an even grid: the cubic term is odd about
    the point). At an end: the polynomial through the nearest up to
    ``2 CURVE_NEIGHBOURS`` points on the one side (a cubic through four).
    """
    below, above = list(range(i)), list(range(i + 1, len(wind_speeds_m_s)))
    if below and above:
        near, degree = below[-CURVE_NEIGHBOURS:] + above[:CURVE_NEIGHBOURS], 2
    else:  # the wind speeds increase: the nearest on the one side
        near, degree = (below[-2 * CURVE_NEIGHBOURS:] or above[:2 * CURVE_NEIGHBOURS]), 3
    if len(near) < 2:
        return math.nan
    x = np.array([wind_speeds_m_s[j] for j in near]) - wind_speeds_m_s[i]
    y = np.array([values[j] for j in near])
    coef = np.polyfit(x, y, min(degree, len(near) - 1))
    return float(coef[-1])


def curve_residuals(wind_speeds_m_s: list[float], power_w: list[float],
                    period_s: list[float]) -> list[float]:
    """How far each point of one kind sits off the smooth curve of the others, in units
    of the flag's threshold: above 1 is off the curve (:func:`off_curve`).

    Parameters
    ----------
    wind_speeds_m_s : list of float
        Wind speeds [m/s], increasing.
    power_w : list of float
        Objective power at each [W].
    period_s : list of float
        Period at each [s] (NaN where unknown: then only the power is checked).

    Returns
    -------
    list of float
        Per point, the larger of its power above the local fit of its neighbours (less
        generated, more drawn: a local optimum is only ever poorer) over
        :data:`JUMP_POWER_RTOL` of the kind's largest ``|P|``, and its period's departure
        over :data:`JUMP_PERIOD_RTOL` of its own. All zero with fewer than
        :data:`MIN_CURVE_SPEEDS` points. A point that does better than its neighbours'
        curve has no power residual: on a coarse grid the curve through two neighbours
        cuts a concave power curve below its middle (AP2 over 6:12:3: the chord predicts
        -2260 W at 9 m/s for the optimum's -2672 W), and it is the neighbours that sit
        below the point's curve then.
    """
    if len(wind_speeds_m_s) < MIN_CURVE_SPEEDS:
        return [0.0] * len(wind_speeds_m_s)
    scale = max(abs(p) for p in power_w)
    residuals = []
    for i in range(len(wind_speeds_m_s)):
        p_fit = _curve_prediction(wind_speeds_m_s, power_w, i)
        r = max(0.0, (power_w[i] - p_fit) / (JUMP_POWER_RTOL * scale))
        if math.isfinite(period_s[i]):
            t_fit = _curve_prediction(wind_speeds_m_s, period_s, i)
            r = max(r, abs(period_s[i] - t_fit) / (JUMP_PERIOD_RTOL * period_s[i]))
        residuals.append(r if math.isfinite(r) else 0.0)
    return residuals


def off_curve(wind_speeds_m_s: list[float], power_w: list[float],
              period_s: list[float]) -> list[int]:
    """Indices of the points of one kind that sit off the smooth curve of the others
    (see :func:`curve_residuals`), the likeliest local optimum first.

    One point off the curve pulls its neighbours' fits off too, so the points are
    ordered by how many of the other flagged points return to the curve without it
    (the culprit clears them), then by how far off they are.
    """
    r = curve_residuals(wind_speeds_m_s, power_w, period_s)
    flagged = [i for i in range(len(r)) if r[i] > 1.0]

    def cleared(i: int) -> int:
        keep = [j for j in range(len(r)) if j != i]
        rest = curve_residuals(*([v[j] for j in keep]
                                 for v in (wind_speeds_m_s, power_w, period_s)))
        return sum(rest[keep.index(j)] <= 1.0 for j in flagged if j != i)

    return sorted(flagged, key=lambda i: (-cleared(i), -r[i]))


@dataclasses.dataclass
class _Search:
    """The re-solves of one kind: which starts were tried and which optimum each came from.

    ``version[k]`` counts the optima ``k`` has had (bumped when a re-solve replaces its
    result), so a start is tried again only once its optimum has changed; ``origin[k]``
    is the ``(source, version)`` its present optimum came from, never tried again;
    ``carried`` holds the scenarios whose present optimum a carried re-solve brought.
    """

    solves: Any
    kind: str
    version: dict
    origin: dict
    by_period: bool = True
    tried: set = dataclasses.field(default_factory=set)
    carried: set = dataclasses.field(default_factory=set)

    def curve(self) -> tuple[list, list[float], list[int]]:
        """The kind's converged scenarios by wind speed, their curve residuals and the
        off-curve ones (:func:`off_curve`); all empty when a power is not finite."""
        ks = sorted((k for k in self.version if self.solves.outcomes[k].success),
                    key=lambda k: k.wind_speed_m_s)
        outs = [self.solves.outcomes[k] for k in ks]
        power = [objective_power_w(self.kind, o.result) for o in outs]
        period = [float(getattr(o.result, "period_s", math.nan)) if self.by_period else math.nan
                  for o in outs]
        if not all(math.isfinite(p) for p in power):
            return [], [], []
        speeds = [k.wind_speed_m_s for k in ks]
        return (ks, curve_residuals(speeds, power, period),
                off_curve(speeds, power, period))

    def worth_trying(self, key: Scenario, source: Scenario) -> bool:
        """Whether ``key`` from ``source``'s present optimum is a start not yet solved."""
        start = (source, self.version[source])
        return (key, *start) not in self.tried and self.origin.get(key) != start

    def resolve(self, key: Scenario, source: Scenario, carried: bool = False,
                back: bool = False) -> bool:
        """Solve ``key`` again from ``source``'s optimum; keep it when better (``carried``,
        ``back``: as :class:`Resolve`). Whether kept."""
        self.tried.add((key, source, self.version[source]))
        o = self.solves.outcomes[key]
        before = objective_power_w(self.kind, o.result)
        attempt, result = self.solves.attempt(key, source, LOCAL_OPTIMUM)
        after = objective_power_w(self.kind, result) if attempt.success else math.nan
        kept = bool(attempt.success and after < before - better_margin_w(before))
        record = Resolve(attempt, after, before, kept, carried=carried, back=back)
        if not kept:
            self.solves.outcomes[key] = dataclasses.replace(o, resolves=(*o.resolves, record))
            return False
        self.solves.replace(dataclasses.replace(
            o, attempts=(*o.attempts, attempt), result=result,
            resolves=(*o.resolves, record)), source)
        self.origin[key] = (source, self.version[source])
        self.version[key] += 1
        if carried:
            self.carried.add(key)
        else:
            self.carried.discard(key)
        return True

    def carry_on(self, ks: list, i: int, step: int) -> None:
        """Carry ``ks[i]``'s new optimum along the kind by ``step`` (+1 up the wind
        speeds, -1 down) while each neighbour's re-solve from it is kept."""
        j = i + step
        while 0 <= j < len(ks) and self.worth_trying(ks[j], ks[j - step]):
            if not self.resolve(ks[j], ks[j - step], carried=True):
                return
            j += step

    def round(self) -> bool:
        """One round: the off-curve scenarios, likeliest first, each re-solved from its
        neighbours (the one nearer its own curve first) until one is kept, which is
        then carried on away from its source and back past it. Whether one was kept."""
        ks, residual, order = self.curve()
        for i in order:
            near = sorted((n for n in (i - 1, i + 1) if 0 <= n < len(ks)),
                          key=lambda n: residual[n])
            for n in near:
                if self.worth_trying(ks[i], ks[n]) and self.resolve(ks[i], ks[n]):
                    self.carry_on(ks, i, i - n)
                    self.carry_on(ks, i, n - i)
                    return True  # the curve has changed: the next round looks again
        return False

    def back_check(self) -> bool:
        """Each scenario solved again from a neighbour whose optimum a kept carried
        re-solve from it replaced (:meth:`carry_on` does not look back; :meth:`round`
        does): the branch found there can be better at the scenario too (AP2, mech-free
        over 4:14:2: 8 m/s, carried from 10 m/s, gains 47 W; 10 m/s, re-solved from that,
        269 W more). Whether one was kept."""
        ks = self.curve()[0]
        kept = False
        for i, key in enumerate(ks):
            for n in (i - 1, i + 1):
                if (0 <= n < len(ks) and ks[n] in self.carried
                        and self.origin[ks[n]][0] == key and self.worth_trying(key, ks[n])):
                    kept = self.resolve(key, ks[n], back=True) or kept
        return kept


def resolve_local_optima(solves: Any, scenarios: Sequence[Scenario],
                         by_period: bool = True) -> None:
    """Re-solve those of ``scenarios`` that sit off their kind's smooth curve.

    Parameters
    ----------
    solves : optimize.service.solves.Solves
        Has solved every one of ``scenarios``; a kept re-solve replaces the scenario's
        outcome, record and warm start there (:meth:`Solves.replace`).
    scenarios : sequence of Scenario
        The scenarios to check (the planned grid), kinds checked in their order here.
    by_period : bool
        Check the period as well as the power (:func:`curve_residuals`). False for
        kinds that started at each speed from their lead kind's optimum
        (:func:`optimize.service.plan.plan_graph`, stage 1): they are on the lead's
        checked branch, and their period moves where their own limits start to bind
        (the paper's drive-limited kinds: a U-shaped period over the wind speed).

    Notes
    -----
    Per kind, in rounds of at most :data:`MAX_RESOLVE_ROUNDS`: each off-curve scenario,
    the likeliest local optimum first (:func:`off_curve`), is solved again from a
    converged neighbouring wind speed (the one nearer its own curve first; never the
    optimum its result came from) and the better optimum (lower objective power by
    more than :func:`better_margin_w`) is kept. A kept optimum is carried on: the next
    wind speed away from its source is solved again from it, and so on while each is
    kept, then the same back past its source, so a better branch found at one point
    reaches the whole kind. A round with no scenario off the curve offers each kept
    optimum back to the neighbour it came from (:meth:`_Search.back_check`). No start
    is solved twice. Every re-solve is recorded in the outcome's ``resolves``.
    """
    for kind in dict.fromkeys(s.kind for s in scenarios):
        own = [s for s in scenarios if s.kind == kind]
        by_name = {solves.outcomes[k].name: k for k in own}
        search = _Search(solves, kind, dict.fromkeys(own, 0),
                         {k: (by_name.get(solves.outcomes[k].attempts[-1].source), 0)
                          for k in own}, by_period)
        for _ in range(MAX_RESOLVE_ROUNDS):
            if not (search.round() or search.back_check()):
                break
