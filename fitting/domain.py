"""The validity domain of a fit: the convex hull of the measured points per quadrant."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, Delaunay, QhullError

from fitting.points import QUADRANTS


def _normalised(speed_rpm, torque_nm, scales):
    return np.column_stack([np.asarray(speed_rpm) / scales[0], np.asarray(torque_nm) / scales[1]])


def _scales(frame) -> tuple[float, float]:
    s = float(np.max(np.abs(frame["speed_rpm"]))) or 1.0
    t = float(np.max(np.abs(frame["torque_nm"]))) or 1.0
    return s, t


def quadrant_hulls(frame) -> dict[str, list[list[float]]]:
    """Counter-clockwise convex-hull polygon ``[[speed_rpm, torque_nm], ...]`` per quadrant.

    A quadrant with fewer than three points, or with collinear points, has no
    area and is left out.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm`` and ``quadrant``.
    """
    scales = _scales(frame)
    out = {}
    for q in QUADRANTS:
        sub = frame[frame["quadrant"] == q]
        if len(sub) < 3:
            continue
        pts = _normalised(sub["speed_rpm"], sub["torque_nm"], scales)
        try:
            hull = ConvexHull(pts)
        except QhullError:
            continue
        verts = pts[hull.vertices] * np.array(scales)
        out[q] = [[float(a), float(b)] for a, b in verts]
    return out


def in_polygon_hull(polygon, speed_rpm, torque_nm) -> np.ndarray:
    """True where (speed, torque) lies inside (or on) a convex polygon [[speed_rpm, torque_nm]].

    Parameters
    ----------
    polygon : sequence of [float, float]
        Convex polygon vertices [rpm, N m], e.g. one quadrant of ``quadrant_hulls``.
    speed_rpm, torque_nm : array_like
        Query points [rpm], [N m] (broadcast together).
    """
    poly = np.asarray(polygon, dtype=float)
    speed, torque = np.broadcast_arrays(np.asarray(speed_rpm, float), np.asarray(torque_nm, float))
    if len(poly) < 3:
        return np.zeros(speed.shape, dtype=bool)
    scales = (float(np.max(np.abs(poly[:, 0]))) or 1.0, float(np.max(np.abs(poly[:, 1]))) or 1.0)
    tri = Delaunay(poly / np.array(scales))
    q = _normalised(speed.ravel(), torque.ravel(), scales)
    # a tiny tolerance keeps grid nodes lying exactly on a hull edge inside
    return (tri.find_simplex(q, tol=1e-9) >= 0).reshape(speed.shape)
