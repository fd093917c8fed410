"""Drive efficiency (paper eqs. 1 and 2), its masking rules, and the gridded map (Fig. 5).

Motor quadrant (the drive delivers shaft power, P_mech > 0)::

    eta_mot = P_mech / P_elec                       # paper eq. (1)

Generator quadrant (P_mech <= 0)::

    eta_gen = (-P_elec) / (-P_mech)                 # paper eq. (2)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from scipy.spatial import ConvexHull, Delaunay, QhullError

from fitting.points import QUADRANTS, quadrant_of

#: Status of a map node or point after the masking rules.
OK, NEAR_AXIS, NEGATIVE, ABOVE_MAX, OUTSIDE_HULL = (
    "ok", "near_axis", "negative", "above_max", "outside_hull"
)

#: Efficiency band edges for the area shares (the last band includes 1.0).
BAND_EDGES = (0.0, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 1.0)


@dataclass(frozen=True)
class MaskingRules:
    """How efficiencies that would distort the map are masked (paper section III-B.3).

    Parameters
    ----------
    mech_frac : float
        Mask points with ``|P_mech| < mech_frac * nominal_power_w`` (near the axes the
        efficiency divides by a small number) [-].
    elec_frac : float
        Mask points with ``|P_elec| < elec_frac * nominal_power_w`` [-].
    nominal_power_w : float
        Nominal power of the drive [W].
    max_efficiency : float
        Efficiencies above this are masked: a drive cannot exceed 1, so such a
        value is a measurement artefact [-].

    Notes
    -----
    Negative efficiencies (the drive draws power while it is driven, or feeds the
    grid while it drives the shaft) are set to 0, as the paper does; masked
    (near-axis, above-max) values become NaN. Both are drawn white.
    """

    mech_frac: float = 0.02
    elec_frac: float = 0.02
    nominal_power_w: float = 8200.0
    max_efficiency: float = 1.0

    def __post_init__(self) -> None:
        for name in ("mech_frac", "elec_frac"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v < 1.0):
                raise ValueError(f"{name} = {v!r}: a fraction in [0, 1) expected")
        if not (np.isfinite(self.nominal_power_w) and self.nominal_power_w > 0):
            raise ValueError("nominal_power_w must be a positive power [W]")
        if not self.max_efficiency > 0:
            raise ValueError("max_efficiency must be positive")

    def to_dict(self) -> dict:
        """Settings plus a one-line statement of each rule (written into the outputs)."""
        d = asdict(self)
        d["rules"] = [
            f"|P_mech| < {self.mech_frac:g} * {self.nominal_power_w:g} W -> masked (NaN)",
            f"|P_elec| < {self.elec_frac:g} * {self.nominal_power_w:g} W -> masked (NaN)",
            "negative efficiency -> 0",
            f"efficiency > {self.max_efficiency:g} -> masked (NaN)",
            "grid nodes outside the quadrant's measured convex hull -> NaN (no extrapolation)",
        ]
        return d


def raw_efficiency(p_mech_w, p_elec_w) -> np.ndarray:
    """Efficiency by paper eqs. (1) and (2), without masking (inf/NaN where dividing by 0)."""
    p_mech = np.asarray(p_mech_w, dtype=float)
    p_elec = np.asarray(p_elec_w, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p_mech > 0, p_mech / p_elec, (-p_elec) / (-p_mech))


def masked_efficiency(p_mech_w, p_elec_w, rules: MaskingRules) -> tuple[np.ndarray, np.ndarray]:
    """Efficiency with the masking rules applied.

    Parameters
    ----------
    p_mech_w, p_elec_w : array_like
        Mechanical and electrical power [W] (sign convention of docs/schemas.md).
    rules : MaskingRules

    Returns
    -------
    eta : numpy.ndarray
        Efficiency [-]: 0 where negative, NaN where masked.
    status : numpy.ndarray of str
        ``ok``, ``near_axis``, ``negative`` or ``above_max`` per point.
    """
    p_mech = np.asarray(p_mech_w, dtype=float)
    p_elec = np.asarray(p_elec_w, dtype=float)
    eta = raw_efficiency(p_mech, p_elec)
    near = (np.abs(p_mech) < rules.mech_frac * rules.nominal_power_w) | (
        np.abs(p_elec) < rules.elec_frac * rules.nominal_power_w
    )
    status = np.full(eta.shape, OK, dtype=object)
    negative = ~near & (eta < 0)
    above = ~near & ~negative & (eta > rules.max_efficiency)
    status[near] = NEAR_AXIS
    status[negative] = NEGATIVE
    status[above] = ABOVE_MAX
    eta = np.where(negative, 0.0, eta)
    eta = np.where(near | above, np.nan, eta)
    return eta, status


def regular_grid(frame, speed_step_rpm: float, torque_step_nm: float):
    """Regular node vectors [rpm], [N m] covering the measured points' bounding box."""
    def axis(values, step):
        lo = np.floor(np.min(values) / step) * step
        hi = np.ceil(np.max(values) / step) * step
        return np.arange(lo, hi + step / 2, step)

    return axis(frame["speed_rpm"], speed_step_rpm), axis(frame["torque_nm"], torque_step_nm)


def _interpolate_in_hull(tri: Delaunay, values: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Piecewise-linear interpolation over a triangulation; NaN outside its convex hull.

    (What scipy's LinearNDInterpolator does, without its slow brute-force search
    for every query point outside the hull.)
    """
    out = np.full(len(query), np.nan)
    # cheap half-plane test first: find_simplex is slow for points outside the hull
    eq = ConvexHull(tri.points).equations
    candidate = np.all(query @ eq[:, :2].T + eq[:, 2] <= 1e-12, axis=1)
    simplex = np.full(len(query), -1)
    simplex[candidate] = tri.find_simplex(query[candidate])
    inside = simplex >= 0
    k = simplex[inside]
    transform = tri.transform[k]
    b = np.einsum("ijk,ik->ij", transform[:, :2], query[inside] - transform[:, 2])
    bary = np.column_stack([b, 1.0 - b.sum(axis=1)])
    out[inside] = np.einsum("ij,ij->i", values[tri.simplices[k]], bary)
    return out


def gridded_map(
    frame: pd.DataFrame,
    rules: MaskingRules,
    *,
    model=None,
    speed_step_rpm: float = 25.0,
    torque_step_nm: float = 1.0,
) -> pd.DataFrame:
    """Efficiency map on a regular speed-torque grid (paper Fig. 5).

    The measured electrical power is interpolated linearly over a Delaunay
    triangulation of each quadrant's points (in scaled coordinates); the
    mechanical power of a node is exact (omega * T). Nodes outside the
    quadrant's convex hull stay NaN: the map is never extrapolated.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm``, ``p_elec_w`` and ``quadrant``.
    rules : MaskingRules
    model : PowerModel, optional
        If given, adds the model's power and efficiency at each node (inside the hull).
    speed_step_rpm, torque_step_nm : float
        Grid spacing [rpm], [N m].

    Returns
    -------
    pandas.DataFrame
        One row per node: ``speed_rpm, torque_nm, quadrant, in_hull, p_mech_w,
        p_elec_w, eta, status`` (and ``p_elec_fit_w, eta_fit`` with a model).
    """
    speeds, torques = regular_grid(frame, speed_step_rpm, torque_step_nm)
    sg, tg = np.meshgrid(speeds, torques, indexing="ij")
    s, t = sg.ravel(), tg.ravel()
    p_mech = s * 2.0 * np.pi / 60.0 * t
    quadrant = quadrant_of(p_mech)
    scales = (float(np.max(np.abs(frame["speed_rpm"]))) or 1.0,
              float(np.max(np.abs(frame["torque_nm"]))) or 1.0)
    p_elec = np.full(s.shape, np.nan)
    for q in QUADRANTS:
        sub = frame[frame["quadrant"] == q]
        nodes = quadrant == q
        if len(sub) < 3 or not nodes.any():
            continue
        pts = np.column_stack([sub["speed_rpm"] / scales[0], sub["torque_nm"] / scales[1]])
        try:
            tri = Delaunay(pts)
        except QhullError:
            continue
        query = np.column_stack([s[nodes] / scales[0], t[nodes] / scales[1]])
        p_elec[nodes] = _interpolate_in_hull(tri, sub["p_elec_w"].to_numpy(), query)
    in_hull = np.isfinite(p_elec)
    eta, status = masked_efficiency(p_mech, p_elec, rules)
    status[~in_hull] = OUTSIDE_HULL
    out = pd.DataFrame({
        "speed_rpm": s, "torque_nm": t, "quadrant": quadrant, "in_hull": in_hull,
        "p_mech_w": p_mech, "p_elec_w": p_elec, "eta": eta, "status": status.astype(str),
    })
    if model is not None:
        p_fit = np.asarray(model.p_elec_w(s, t), dtype=float)
        eta_fit, _ = masked_efficiency(p_mech, p_fit, rules)
        out["p_elec_fit_w"] = p_fit
        out["eta_fit"] = np.where(in_hull, eta_fit, np.nan)
    return out


def band_shares(map_frame: pd.DataFrame, edges=BAND_EDGES) -> pd.DataFrame:
    """Share of each quadrant's hull area per efficiency band (regular grid: node share).

    Rows: quadrant x band, where the bands are the intervals of ``edges`` plus
    ``masked`` (near the axes or above max) and ``negative`` (set to 0).
    """
    rows = []
    for q in QUADRANTS:
        sub = map_frame[(map_frame["quadrant"] == q) & map_frame["in_hull"]]
        n = len(sub)
        if n == 0:
            continue
        ok = sub[sub["status"] == OK]["eta"].to_numpy()
        for k in range(len(edges) - 1):
            lo, hi = edges[k], edges[k + 1]
            last = k == len(edges) - 2
            inside = (ok >= lo) & ((ok <= hi) if last else (ok < hi))
            rows.append({"quadrant": q, "band": f"{lo:.2f}-{hi:.2f}", "eta_low": lo,
                         "eta_high": hi, "n_nodes": int(inside.sum()),
                         "area_share": float(inside.sum() / n)})
        for label, statuses in (("negative", (NEGATIVE,)), ("masked", (NEAR_AXIS, ABOVE_MAX))):
            k = int(sub["status"].isin(statuses).sum())
            rows.append({"quadrant": q, "band": label, "eta_low": np.nan, "eta_high": np.nan,
                         "n_nodes": k, "area_share": k / n})
    return pd.DataFrame(rows)


def peak_points(map_frame: pd.DataFrame, frame: pd.DataFrame, rules: MaskingRules) -> dict:
    """Peak efficiency per quadrant: on the gridded map and among the measured points."""
    eta_pts, status_pts = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    out = {}
    for q in QUADRANTS:
        entry = {}
        grid = map_frame[(map_frame["quadrant"] == q) & (map_frame["status"] == OK)]
        if len(grid):
            row = grid.loc[grid["eta"].idxmax()]
            entry["map"] = {"speed_rpm": float(row["speed_rpm"]),
                            "torque_nm": float(row["torque_nm"]), "eta": float(row["eta"])}
        sel = (frame["quadrant"].to_numpy() == q) & (status_pts == OK)
        if sel.any():
            k = int(np.flatnonzero(sel)[np.argmax(eta_pts[sel])])
            entry["measured"] = {"speed_rpm": float(frame["speed_rpm"].iloc[k]),
                                 "torque_nm": float(frame["torque_nm"].iloc[k]),
                                 "eta": float(eta_pts[k])}
        if entry:
            out[q] = entry
    return out
