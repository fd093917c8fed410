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

Several curves on one grid (the electrical and the mechanical power of the same
cycles) are refined together: ``power`` returns one value per curve, each
interval's estimate is taken relative to its own curve's AEP (floored at a tenth
of the largest curve's AEP, so a curve that delivers almost nothing does not ask
for every split), and the interval with the largest relative estimate is split.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from energy.aep import aep_mwh
from energy.site import HOURS_PER_YEAR, Distribution


@dataclass(frozen=True)
class RefinedGrid:
    """Outcome of :func:`refine_grid`.

    Attributes
    ----------
    wind_speed_m_s, p_w : ndarray
        The final grid [m/s] and powers [W] (failed solves left out); ``p_w`` has
        shape ``(n,)`` for one curve, ``(n, n_curves)`` for several.
    aep_mwh : float or ndarray
        AEP of the final grid's curve(s).
    history : list of (float, float or ndarray)
        (wind added, AEP after adding it) in order.
    failed : list of float
        Wind speeds whose solve failed.
    """

    wind_speed_m_s: np.ndarray
    p_w: np.ndarray
    aep_mwh: float | np.ndarray
    history: list[tuple[float, float | np.ndarray]]
    failed: list[float]


Power = float | Sequence[float]


def refine_grid(power: Callable[[float], Power | None], start_m_s: tuple[float, ...],
                site: Distribution, tol: float = 0.002, min_step_m_s: float = 0.25,
                max_points: int = 40, known: Mapping[float, Power] | None = None) -> RefinedGrid:
    """Refine a wind grid where the curve bends (see the module text).

    Parameters
    ----------
    power : callable
        ``power(wind) -> P [W]`` (negative = generated), or a sequence of powers of
        several curves, or None when the solve failed.
    start_m_s : tuple of float
        The coarse grid [m/s], increasing.
    site : Weibull or Histogram
    tol : float
        Stop refining an interval when the midpoint changed the AEP by less than
        this share of the AEP (and its neighbours' curvature says the same).
    min_step_m_s : float
        Never split an interval shorter than twice this [m/s].
    max_points : int
        Hard cap on the grid size (failed solves count).
    known : mapping, optional
        Wind [m/s] -> power(s) already solved: used as given, never passed to ``power``.
    """
    scalar = True
    pts: dict[float, np.ndarray] = {}
    failed: list[float] = []

    def add(v: float, p: Power | None) -> bool:
        nonlocal scalar
        if p is None:
            failed.append(v)
            return False
        scalar = scalar and np.ndim(p) == 0
        pts[v] = np.atleast_1d(np.asarray(p, dtype=float))
        return True

    for v, p in (known or {}).items():
        add(float(v), p)
    for v in start_m_s:
        if float(v) not in pts:
            add(float(v), power(float(v)))
    history: list[tuple[float, float | np.ndarray]] = []
    closed: set[tuple[float, float]] = set()

    def current() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        w = np.array(sorted(pts))
        p = np.array([pts[x] for x in w]).reshape(len(w), -1)
        aep = (np.array([aep_mwh(w, p[:, q], site) for q in range(p.shape[1])])
               if len(w) > 1 else np.zeros(p.shape[1]))
        return w, p, aep

    def out(value: np.ndarray):
        return float(value[0]) if scalar else value

    while len(pts) + len(failed) < max_points:
        w, p, aep = current()
        if len(w) < 2:
            break
        scale = np.maximum(np.abs(aep), max(0.1 * float(np.max(np.abs(aep))), 1e-12))
        scores = [s for s in _interval_scores(w, p, site, scale, min_step_m_s)
                  if (s[1], s[2]) not in closed]
        if not scores:
            break
        rel, a, b = max(scores)
        if np.isfinite(rel) and rel < tol:
            break
        mid = round(0.5 * (a + b), 6)
        if not add(mid, power(mid)):
            closed.add((a, b))
            continue
        history.append((mid, out(current()[2])))
    w, p, aep = current()
    return RefinedGrid(w, p[:, 0] if scalar else p, out(aep), history, failed)


def _interval_scores(w: np.ndarray, p: np.ndarray, site: Distribution, scale: np.ndarray,
                     min_step_m_s: float) -> list[tuple[float, float, float]]:
    """``(estimated error / scale, a, b)`` of every interval ``[a, b]`` of the grid ``w``
    [m/s] long enough to split: the chord's error bound from the neighbours' curvature of
    the powers ``p`` [W] (one column per curve), weighted by the site's hours in it [MWh]."""
    scores = []
    for i in range(len(w) - 1):
        a, b = w[i], w[i + 1]
        if b - a < 2 * min_step_m_s - 1e-9:
            continue
        curv = []
        for j in (i - 1, i + 1):  # second differences around the interval
            if 0 <= j and j + 2 <= len(w) - 1 and j + 1 < len(w):
                x0, x1, x2 = w[j], w[j + 1], w[j + 2]
                slope_l = (p[j + 1] - p[j]) / (x1 - x0)
                slope_r = (p[j + 2] - p[j + 1]) / (x2 - x1)
                curv.append(np.abs(slope_r - slope_l) / (x2 - x0))
        c = np.max(curv, axis=0) if curv else np.full(p.shape[1], np.inf)
        mass = float(site.cdf(b) - site.cdf(a))
        est = c * (b - a) ** 2 / 8 * mass * HOURS_PER_YEAR / 1e6  # chord error bound
        scores.append((float(np.max(est / scale)), a, b))
    return scores
