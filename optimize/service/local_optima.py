"""Local optima: a scenario off its kind's smooth curve is solved again from its neighbours.

A cold start or a chain can land on a local optimum: one wind speed of a kind then
disagrees with the curve through its neighbours (a jump in average power or
period, :func:`off_curve`). :func:`resolve_local_optima` solves each such
scenario again, warm-started from each converged neighbouring wind speed of its
kind other than the one its result came from, and keeps the better optimum.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from optimize.kinds import KINDS
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
MAX_RESOLVE_ROUNDS = 3


#: the role of a re-solve in the progress events (:meth:`Solver.attempt`)
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


def off_curve(wind_speeds_m_s: list[float], power_w: list[float],
              period_s: list[float]) -> list[int]:
    """Indices of the points of one kind that sit off the smooth curve of the others.

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
    list of int
        Points whose power is above the local fit of their neighbours (less generated,
        more drawn: a local optimum is only ever poorer) by more than
        :data:`JUMP_POWER_RTOL` of the kind's largest ``|P|``, or whose period departs
        by more than :data:`JUMP_PERIOD_RTOL` of its own. A point that does better than
        its neighbours' curve is not one: on a coarse grid the curve through two
        neighbours cuts a concave power curve below its middle (AP2 over 6:12:3: the
        chord predicts -2260 W at 9 m/s for the optimum's -2672 W), and it is the
        neighbours that sit below the point's curve then.
    """
    if len(wind_speeds_m_s) < MIN_CURVE_SPEEDS:
        return []
    scale = max(abs(p) for p in power_w)
    flagged = []
    for i in range(len(wind_speeds_m_s)):
        p_fit = _curve_prediction(wind_speeds_m_s, power_w, i)
        jump = power_w[i] - p_fit > JUMP_POWER_RTOL * scale
        if math.isfinite(period_s[i]):
            t_fit = _curve_prediction(wind_speeds_m_s, period_s, i)
            jump = jump or abs(period_s[i] - t_fit) > JUMP_PERIOD_RTOL * period_s[i]
        if jump:
            flagged.append(i)
    return flagged


def resolve_local_optima(solver: Any, keys: Sequence[tuple[str, float]]) -> None:
    """Re-solve the scenarios of ``keys`` that sit off their kind's smooth curve.

    Parameters
    ----------
    solver : optimize.service.solver.Solver
        Has solved every ``(kind, wind_speed_m_s)`` of ``keys``; a kept re-solve replaces the
        scenario's outcome, record and warm start there (:meth:`Solver.replace`).
    keys : sequence of (kind, wind_speed_m_s)
        The scenarios to check (the planned grid), kinds checked in their order here.

    Notes
    -----
    Each off-curve scenario is solved again warm-started from each converged
    neighbouring wind speed of its kind other than the one its result came from,
    and the better optimum (lower objective power by more than
    :func:`better_margin_w`) is kept. Every re-solve is recorded in the outcome's
    ``resolves``.
    """
    version = dict.fromkeys(keys, 0)  # bumped when a result is replaced
    tried: set[tuple] = set()
    for kind in dict.fromkeys(k for k, _ in keys):
        for _ in range(MAX_RESOLVE_ROUNDS):
            ks = sorted((k for k in keys if k[0] == kind and solver.outcomes[k].success),
                        key=lambda k: k[1])
            outs = [solver.outcomes[k] for k in ks]
            power = [objective_power_w(kind, o.result) for o in outs]
            period = [float(getattr(o.result, "period_s", math.nan)) for o in outs]
            if not all(math.isfinite(p) for p in power):
                break
            replaced = False
            for i in off_curve([k[1] for k in ks], power, period):
                for n in (i - 1, i + 1):
                    if not 0 <= n < len(ks):
                        continue
                    o, src = solver.outcomes[ks[i]], solver.outcomes[ks[n]]
                    tag = (ks[i], ks[n], version[ks[n]])
                    if tag in tried or (o.attempts[-1].source == src.name
                                        and version[ks[n]] == 0):
                        continue
                    tried.add(tag)
                    before = objective_power_w(kind, o.result)
                    attempt, result = solver.attempt(kind, o.wind_speed_m_s, ks[n],
                                                     LOCAL_OPTIMUM)
                    after = objective_power_w(kind, result) if attempt.success else math.nan
                    kept = bool(attempt.success and after < before - better_margin_w(before))
                    record = Resolve(attempt, after, before, kept)
                    if kept:
                        solver.replace(dataclasses.replace(
                            o, attempts=(*o.attempts, attempt), result=result,
                            resolves=(*o.resolves, record)), ks[n])
                        version[ks[i]] += 1
                        replaced = True
                        break  # the next round checks the curve again with it
                    solver.outcomes[ks[i]] = dataclasses.replace(
                        o, resolves=(*o.resolves, record))
            if not replaced:
                break
