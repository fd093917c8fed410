"""Annual energy of a power curve under a wind-speed distribution.

Sign convention: the optimize stage's powers are negative when generated; the
energy here is the energy *delivered* (to the grid for electrical power, to the
drum shaft's load for mechanical power), ``d(v) = -P(v)``, reported positive in
MWh per year.

The curve between grid points
-----------------------------
The delivered power is linear between neighbouring converged grid points
(``knots``). Where it changes sign between two knots the zero crossing is a
knot of its own; when the optimize stage's bisection found the cut-in speed
inside that interval, the crossing is put there instead of the linear
estimate. The system does not fly where the optimal cycle would draw power
from the grid, so the delivered power is ``max(d, 0)``. Below the first and
above the last grid point nothing is delivered: cut-in and cut-out are the
curve's own (the probability outside the grid is reported, so a user sees
what a wider grid would add). With ``max(d, 0)`` piecewise linear and the
distribution's CDF ``F`` and first partial moment ``M``, the expectation is
exact: ``sum over segments of alpha (F(b) - F(a)) + beta (M(b) - M(a))``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from energy.site import HOURS_PER_YEAR, Distribution, energy_share

#: W h -> MW h
WH_PER_MWH = 1.0e6


def delivered_knots(
    wind_speed_m_s: np.ndarray, p_w: np.ndarray, cut_in_m_s: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Knots of the delivered-power curve ``max(-P, 0)``, zero crossings included.

    Parameters
    ----------
    wind_speed_m_s : ndarray
        Grid wind speeds [m/s], strictly increasing.
    p_w : ndarray
        Cycle-average power [W] at those speeds (negative = generated).
    cut_in_m_s : float, optional
        Cut-in speed [m/s] from a bisection; used as the crossing when it lies
        in the interval where the delivered power turns positive.

    Returns
    -------
    (ndarray, ndarray)
        Knot speeds [m/s] and delivered power [W] (>= 0), linear in between.
    """
    v = np.asarray(wind_speed_m_s, dtype=float)
    d = -np.asarray(p_w, dtype=float)
    if v.ndim != 1 or v.shape != d.shape or len(v) == 0:
        raise ValueError("wind and power must be 1-D arrays of equal, non-zero length")
    if np.any(np.diff(v) <= 0) or not np.all(np.isfinite(d)):
        raise ValueError("wind speeds must increase strictly and powers be finite")
    kv, kd = [v[0]], [d[0]]
    for a, b, da, db in zip(v[:-1], v[1:], d[:-1], d[1:], strict=True):
        if (da > 0) != (db > 0) and da != 0 and db != 0:
            x = a + (b - a) * da / (da - db)  # linear zero crossing
            if cut_in_m_s is not None and da <= 0 < db and a < cut_in_m_s < b:
                x = cut_in_m_s
            kv.append(x)
            kd.append(0.0)
        kv.append(b)
        kd.append(db)
    return np.array(kv), np.clip(np.array(kd), 0.0, None)


def expected_power_w(knot_v: np.ndarray, knot_d: np.ndarray, dist: Distribution) -> float:
    """Mean delivered power [W] of a piecewise-linear curve, zero outside its knots (exact)."""
    a, b = np.asarray(knot_v[:-1], float), np.asarray(knot_v[1:], float)
    da, db = np.asarray(knot_d[:-1], float), np.asarray(knot_d[1:], float)
    if len(knot_v) < 2:
        return 0.0
    beta = (db - da) / (b - a)
    alpha = da - beta * a
    return float(np.sum(alpha * (dist.cdf(b) - dist.cdf(a))
                        + beta * (dist.partial_mean(b) - dist.partial_mean(a))))


def aep_mwh(wind_speed_m_s, p_w, dist: Distribution, cut_in_m_s: float | None = None) -> float:
    """Annual energy delivered [MWh/yr] (8760 h) by the curve ``P(wind)`` (negative = generated)."""
    kv, kd = delivered_knots(wind_speed_m_s, p_w, cut_in_m_s)
    return expected_power_w(kv, kd, dist) * HOURS_PER_YEAR / WH_PER_MWH


def aep_sensitivity(wind_speed_m_s, p_w, dist: Distribution, cut_in_m_s: float | None = None,
                    step_w: float = 1e-3) -> np.ndarray:
    """``d AEP / d P_i`` [MWh/yr per W] at each grid point (central differences).

    The AEP is piecewise linear in the grid powers, so a small step gives the
    exact slope away from a point whose power is zero.
    """
    p = np.asarray(p_w, dtype=float)
    out = np.empty_like(p)
    for i in range(len(p)):
        hi, lo = p.copy(), p.copy()
        hi[i] += step_w
        lo[i] -= step_w
        out[i] = (aep_mwh(wind_speed_m_s, hi, dist, cut_in_m_s)
                  - aep_mwh(wind_speed_m_s, lo, dist, cut_in_m_s)) / (2 * step_w)
    return out


@dataclass(frozen=True)
class CurveEnergy:
    """Annual energy of one power curve (one quantity of one scenario kind).

    Attributes
    ----------
    aep_mwh : float
        Energy delivered per year [MWh/yr] (positive).
    mean_power_w : float
        Mean delivered power [W].
    capacity_factor : float
        ``mean_power_w / nominal_power_w`` [-].
    cut_in_m_s : float or None
        Where the delivered power turns positive inside the grid [m/s]: the optimize
        stage's bisected cut-in when it lies there, else the linear zero crossing
        between the grid points around it; None when the curve delivers already at the
        grid's first speed (the cut-in lies below the grid: not found) or never.
    cut_out_m_s : float or None
        Highest speed with positive delivered power (the last grid point when it delivers) [m/s].
    share_below_grid, share_above_grid : float
        Probability of wind below the first / above the last grid point [-]:
        hours counted with zero power.
    energy_below_grid, energy_above_grid : float
        The site's available wind energy (``rho v^3 / 2`` over the year) below the first
        / above the last grid point, as a share of all of it [-]
        (:func:`energy.site.energy_share`).
    grid_m_s : tuple of float
        First and last grid speed [m/s].
    share_left_out : float
        Probability of the hours the grid leaves out [-]: those above it, and those
        below it unless the curve delivers nothing at its first speed (below a cut-in
        inside the grid no power is lost by stopping there).
    energy_left_out : float
        The same in the site's available wind energy [-].
    delivers_at_grid_start : bool
        Whether the curve delivers power at the grid's first speed, so the hours below
        it are an undercount (the cut-in lies below the grid).
    """

    aep_mwh: float
    mean_power_w: float
    capacity_factor: float
    cut_in_m_s: float | None
    cut_out_m_s: float | None
    share_below_grid: float
    share_above_grid: float
    grid_m_s: tuple[float, float]
    share_left_out: float
    energy_below_grid: float = 0.0
    energy_above_grid: float = 0.0
    energy_left_out: float = 0.0
    delivers_at_grid_start: bool = False


def curve_energy(wind_speed_m_s, p_w, dist: Distribution, nominal_power_w: float,
                 cut_in_m_s: float | None = None) -> CurveEnergy:
    """AEP, capacity factor, cut-in/out of one curve (see :func:`aep_mwh`)."""
    kv, kd = delivered_knots(wind_speed_m_s, p_w, cut_in_m_s)
    mean = expected_power_w(kv, kd, dist)
    positive = np.flatnonzero(kd > 0)
    below, above = float(dist.cdf(kv[0])), float(1.0 - dist.cdf(kv[-1]))
    e_below, e_above = energy_share(dist, 0.0, kv[0]), energy_share(dist, kv[-1])
    delivers = bool(kd[0] > 0)
    cut_in = cut_out = None
    if len(positive):
        first, last = positive[0], positive[-1]
        cut_in = float(kv[first - 1]) if first > 0 and kd[first - 1] == 0 else None
        cut_out = float(kv[last + 1] if last + 1 < len(kv) and kd[last + 1] == 0 else kv[last])
    return CurveEnergy(
        aep_mwh=mean * HOURS_PER_YEAR / WH_PER_MWH,
        mean_power_w=mean,
        capacity_factor=mean / nominal_power_w,
        cut_in_m_s=cut_in,
        cut_out_m_s=cut_out,
        share_below_grid=below,
        share_above_grid=above,
        grid_m_s=(float(kv[0]), float(kv[-1])),
        share_left_out=above + (below if delivers else 0.0),
        energy_below_grid=e_below,
        energy_above_grid=e_above,
        energy_left_out=e_above + (e_below if delivers else 0.0),
        delivers_at_grid_start=delivers,
    )
