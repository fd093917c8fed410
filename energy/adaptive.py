"""Adaptive wind grid: add points where the power curve bends, until the AEP settles.

Linear interpolation between grid points (:mod:`energy.aep`) is exact on straight
stretches of the curve; its error sits where the curve bends: at cut-in, where a
drive limit becomes active, where the growth with the cube of the wind turns.
Starting from a coarse grid, :func:`refine_grid` solves the midpoint of the
interval whose linear interpolation is least certain in energy terms,

    e_i = 8760 h * |P(mid) - (P(a) + P(b)) / 2| * Prob(a < v < b),

(the midpoint's departure from the chord, weighted by the wind probability of the
interval). The midpoint is not known before it is solved, so the interval to
split is chosen by an estimate: the chord error bound ``c h^2 / 8`` with ``c``
the largest second difference of the neighbouring points (unknown, so split
first, at the grid's ends), times the interval's probability. Refinement stops
when every estimate is below ``tol`` of the AEP, the spacing would drop below
``min_step_m_s``, or the grid holds ``max_points``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from energy.aep import aep_mwh
from energy.site import HOURS_PER_YEAR, Distribution


@dataclass(frozen=True)
class RefinedGrid:
    """Outcome of :func:`refine_grid`.

    Attributes
    ----------
    wind_m_s, p_w : ndarray
        The final grid [m/s] and powers [W] (failed solves left out).
    aep_mwh : float
        AEP of the final grid's curve.
    history : list of (float, float)
        (wind added, AEP after adding it) in order.
    failed : list of float
        Wind speeds whose solve failed.
    """

    wind_m_s: np.ndarray
    p_w: np.ndarray
    aep_mwh: float
    history: list[tuple[float, float]]
    failed: list[float]


def refine_grid(power: Callable[[float], float | None], start_m_s: tuple[float, ...],
                site: Distribution, tol: float = 0.002, min_step_m_s: float = 0.25,
                max_points: int = 40) -> RefinedGrid:
    """Refine a wind grid where the curve bends (see the module text).

    Parameters
    ----------
    power : callable
        ``power(wind) -> P [W]`` (negative = generated), or None when the solve failed.
    start_m_s : tuple of float
        The coarse grid [m/s], increasing.
    site : Weibull or Histogram
    tol : float
        Stop refining an interval when the midpoint changed the AEP by less than
        this share of the AEP (and its neighbours' curvature says the same).
    min_step_m_s : float
        Never split an interval shorter than twice this [m/s].
    max_points : int
        Hard cap on the grid size.
    """
    pts: dict[float, float] = {}
    failed: list[float] = []
    for v in start_m_s:
        p = power(float(v))
        (failed.append(float(v)) if p is None else pts.__setitem__(float(v), float(p)))
    history: list[tuple[float, float]] = []
    closed: set[tuple[float, float]] = set()

    def current() -> tuple[np.ndarray, np.ndarray, float]:
        w = np.array(sorted(pts))
        p = np.array([pts[x] for x in w])
        return w, p, aep_mwh(w, p, site) if len(w) > 1 else 0.0

    while len(pts) + len(failed) < max_points:
        w, p, aep = current()
        if len(w) < 2:
            break
        # estimated error of each open interval: chord vs the neighbours' curvature
        scores = []
        for i in range(len(w) - 1):
            a, b = w[i], w[i + 1]
            if (a, b) in closed or b - a < 2 * min_step_m_s - 1e-9:
                continue
            curv = []
            for j in (i - 1, i + 1):  # second differences around the interval
                if 0 <= j and j + 2 <= len(w) - 1 and j + 1 < len(w):
                    x0, x1, x2 = w[j], w[j + 1], w[j + 2]
                    slope_l = (p[j + 1] - p[j]) / (x1 - x0)
                    slope_r = (p[j + 2] - p[j + 1]) / (x2 - x1)
                    curv.append(abs(slope_r - slope_l) / (x2 - x0))
            c = max(curv) if curv else np.inf
            mass = float(site.cdf(b) - site.cdf(a))
            est = c * (b - a) ** 2 / 8 * mass * HOURS_PER_YEAR / 1e6  # chord error bound
            scores.append((est, a, b))
        if not scores:
            break
        est, a, b = max(scores)
        if np.isfinite(est) and est < tol * max(abs(aep), 1e-12):
            break
        mid = round(0.5 * (a + b), 6)
        pm = power(mid)
        if pm is None:
            failed.append(mid)
            closed.add((a, b))
            continue
        pts[mid] = float(pm)
        history.append((mid, current()[2]))
    w, p, aep = current()
    return RefinedGrid(w, p, aep, history, failed)
