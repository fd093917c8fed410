"""The validity domain of a fit: the measured speed-torque envelope per quadrant.

A bench measures a drive inside its envelope, and that envelope is rarely
convex: above base speed a drive is power limited (torque ~ 1 / speed), so the
convex hull of the points covers a region nobody measured. The envelope used
here follows the points instead:

1. Cut the quadrant's speed range into bands of width
   ``band_frac * max |speed|`` (fixed edges from the lowest speed).
2. In each band keep the point of highest and the point of lowest torque.
3. The upper boundary is the piecewise-linear line through the band maxima, the
   lower boundary the line through the band minima (constant beyond the first
   and last of them, to the quadrant's extreme speeds); where the two would
   cross, the region pinches to a line.

The result is an x-monotone polygon whose vertices are measured points (or lie
on segments between two of them). It extends beyond a measured point by at most
one band in speed, where the first or last band's extreme is carried to the end
of the speed range; between two neighbouring band extremes it follows their
chord.
"""

from __future__ import annotations

import numpy as np

from fitting.points import QUADRANTS

#: Default speed band width of the envelope, a fraction of the quadrant's largest |speed|.
BAND_FRAC = 0.02


def band_width_rpm(speed_rpm, band_frac: float = BAND_FRAC) -> float:
    """Speed band width [rpm]: ``band_frac`` times the largest |speed| (1 rpm at least)."""
    speed = np.asarray(speed_rpm, dtype=float)
    return max(float(band_frac * np.max(np.abs(speed))), 1.0) if speed.size else 1.0


def envelope_polygon(speed_rpm, torque_nm, band_width: float) -> list[list[float]]:
    """The measured envelope of one quadrant's points (see the module docstring).

    Parameters
    ----------
    speed_rpm, torque_nm : array_like
        The quadrant's operating points [rpm], [N m], drum frame.
    band_width : float
        Speed band width [rpm].

    Returns
    -------
    list of [float, float]
        Polygon vertices ``[speed_rpm, torque_nm]``: the upper boundary with
        rising speed, then the lower boundary with falling speed. Empty with
        fewer than three points or no extent in speed or torque.
    """
    s = np.asarray(speed_rpm, dtype=float)
    t = np.asarray(torque_nm, dtype=float)
    if s.size < 3 or np.ptp(s) <= 0 or np.ptp(t) <= 0:
        return []
    band = np.floor((s - s.min()) / band_width).astype(np.int64)
    order = np.lexsort((t, band))  # by band, then torque within the band
    b_sorted = band[order]
    first = np.flatnonzero(np.r_[True, b_sorted[1:] != b_sorted[:-1]])
    last = np.r_[first[1:] - 1, b_sorted.size - 1]
    lo_idx, hi_idx = order[first], order[last]

    def chain(idx):
        k = np.argsort(s[idx], kind="stable")
        return s[idx][k], t[idx][k]

    upper_s, upper_t = chain(hi_idx)
    lower_s, lower_t = chain(lo_idx)
    xs = np.unique(np.concatenate([[s.min(), s.max()], upper_s, lower_s]))
    upper = np.interp(xs, upper_s, upper_t)
    lower = np.minimum(np.interp(xs, lower_s, lower_t), upper)
    poly = [[float(a), float(b)] for a, b in zip(xs, upper, strict=True)]
    poly += [[float(a), float(b)] for a, b in zip(xs[::-1], lower[::-1], strict=True)]
    return poly


def quadrant_envelopes(frame, band_frac: float = BAND_FRAC) -> dict[str, dict]:
    """The measured envelope of each quadrant that has one.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm`` and ``quadrant``.
    band_frac : float
        Band width as a fraction of the quadrant's largest |speed| [-].

    Returns
    -------
    dict
        ``quadrant -> {"polygon": [[speed_rpm, torque_nm], ...], "band_width_rpm": w,
        "n_points": n}``; a quadrant with fewer than three points or without extent
        in speed or torque is left out.
    """
    out = {}
    for q in QUADRANTS:
        sub = frame[frame["quadrant"] == q]
        if len(sub) < 3:
            continue
        w = band_width_rpm(sub["speed_rpm"], band_frac)
        poly = envelope_polygon(sub["speed_rpm"], sub["torque_nm"], w)
        if poly:
            out[q] = {"polygon": poly, "band_width_rpm": w, "n_points": int(len(sub))}
    return out


def _edges(polygon):
    p = np.asarray(polygon, dtype=float)
    return p, np.roll(p, -1, axis=0)


def in_polygon(polygon, speed_rpm, torque_nm, tol: float = 1e-9) -> np.ndarray:
    """True where (speed, torque) lies inside or on a simple polygon (even-odd rule).

    Parameters
    ----------
    polygon : sequence of [float, float]
        Vertices ``[speed_rpm, torque_nm]`` of a simple (possibly non-convex) polygon.
    speed_rpm, torque_nm : array_like
        Query points [rpm], [N m] (broadcast together).
    tol : float
        Points within ``tol`` times the polygon's size of an edge count as inside [-].
    """
    speed, torque = np.broadcast_arrays(np.asarray(speed_rpm, float), np.asarray(torque_nm, float))
    poly = np.asarray(polygon, dtype=float)
    if len(poly) < 3:
        return np.zeros(speed.shape, dtype=bool)
    x, y = speed.ravel(), torque.ravel()
    a, b = _edges(poly)
    inside = np.zeros(x.shape, dtype=bool)
    for (x0, y0), (x1, y1) in zip(a, b, strict=True):
        crosses = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (x < x_cross)
    scales = _scales(poly)
    on_edge = distance_to_polygon(poly, x, y, scales) <= tol
    return (inside | on_edge).reshape(speed.shape)


def _scales(poly: np.ndarray) -> tuple[float, float]:
    return (float(np.max(np.abs(poly[:, 0]))) or 1.0, float(np.max(np.abs(poly[:, 1]))) or 1.0)


def distance_to_polygon(polygon, speed_rpm, torque_nm, scales) -> np.ndarray:
    """Distance from each point to the polygon's boundary in scaled coordinates [-].

    Parameters
    ----------
    polygon : sequence of [float, float]
        Vertices ``[speed_rpm, torque_nm]``.
    speed_rpm, torque_nm : array_like
        Query points [rpm], [N m].
    scales : (float, float)
        Speed [rpm] and torque [N m] that count as distance 1.
    """
    speed, torque = np.broadcast_arrays(np.asarray(speed_rpm, float), np.asarray(torque_nm, float))
    p = np.asarray(polygon, dtype=float) / np.asarray(scales, dtype=float)
    x, y = speed.ravel() / scales[0], torque.ravel() / scales[1]
    best = np.full(x.shape, np.inf)
    for (x0, y0), (x1, y1) in zip(p, np.roll(p, -1, axis=0), strict=True):
        dx, dy = x1 - x0, y1 - y0
        length2 = dx * dx + dy * dy
        u = np.zeros_like(x) if length2 == 0 else np.clip(((x - x0) * dx + (y - y0) * dy)
                                                          / length2, 0.0, 1.0)
        best = np.minimum(best, np.hypot(x - (x0 + u * dx), y - (y0 + u * dy)))
    return best.reshape(speed.shape)


def in_domain(domain: dict | None, speed_rpm, torque_nm) -> np.ndarray:
    """True where (speed, torque) lies in any quadrant polygon of a validity domain.

    Parameters
    ----------
    domain : dict or None
        ``quadrant -> polygon`` as in ``power_model.json``; None: no domain, all True.
    speed_rpm, torque_nm : array_like
        Query points [rpm], [N m].
    """
    speed, torque = np.broadcast_arrays(np.asarray(speed_rpm, float), np.asarray(torque_nm, float))
    if not domain:
        return np.ones(speed.shape, dtype=bool)
    inside = np.zeros(speed.shape, dtype=bool)
    for poly in domain.values():
        inside |= in_polygon(poly, speed, torque)
    return inside


def domain_excursion(speed_rpm, torque_nm, weight, domain: dict | None,
                     scales: tuple[float, float]) -> dict:
    """How much of a trajectory lies outside a model's validity domain, and its worst point.

    Parameters
    ----------
    speed_rpm, torque_nm : array_like
        The trajectory's drum speed [rpm] and torque [N m] at its points.
    weight : array_like
        Each point's share of the cycle time (e.g. quadrature weights) [-, any scale].
    domain : dict or None
        ``quadrant -> polygon`` of ``power_model.json``; None means no domain is known.
    scales : (float, float)
        Speed [rpm] and torque [N m] that count as distance 1 (e.g. the drive's limits,
        :meth:`kernel.drive.Drive.box`).

    Returns
    -------
    dict
        ``time_fraction_outside`` [-] (NaN without a domain), ``n_points_outside``,
        and the worst point: ``worst_speed_rpm``, ``worst_torque_nm``,
        ``worst_distance`` (scaled distance to the nearest domain polygon, 0 when
        every point is inside).
    """
    speed = np.asarray(speed_rpm, dtype=float).ravel()
    torque = np.asarray(torque_nm, dtype=float).ravel()
    w = np.broadcast_to(np.asarray(weight, dtype=float), speed.shape)
    none = {"time_fraction_outside": float("nan"), "n_points_outside": 0,
            "worst_speed_rpm": float("nan"), "worst_torque_nm": float("nan"),
            "worst_distance": float("nan")}
    if not domain or speed.size == 0:
        return none
    outside = ~in_domain(domain, speed, torque)
    distance = np.where(outside, np.inf, 0.0)
    for poly in domain.values():
        if len(poly) >= 3:
            distance = np.where(outside, np.minimum(distance, distance_to_polygon(
                poly, speed, torque, scales)), 0.0)
    k = int(np.argmax(distance))
    total = float(np.sum(w))
    return {"time_fraction_outside": float(np.sum(w[outside]) / total) if total > 0 else
            float("nan"),
            "n_points_outside": int(outside.sum()),
            "worst_speed_rpm": float(speed[k]) if outside.any() else float("nan"),
            "worst_torque_nm": float(torque[k]) if outside.any() else float("nan"),
            "worst_distance": float(distance[k])}
