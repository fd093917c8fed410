"""The gridded efficiency map (paper Fig. 5): the measured loss interpolated inside each
quadrant's measured envelope, its efficiency bands and peaks.

The map never invents efficiency: it is drawn only inside each quadrant's measured
envelope (:mod:`fitting.domain`), it interpolates the measured *loss*
``P_elec - P_mech`` rather than ``P_elec``, no node shows an efficiency above the
quadrant's ceiling (:func:`fitting.point_uncertainty.efficiency_ceilings`), and its
grid, read bilinearly, shows every accepted point within its uncertainty
(:mod:`fitting.map_honesty`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial import ConvexHull, Delaunay, QhullError

from fitting.domain import in_polygon, quadrant_envelopes
from fitting.efficiency import (
    ABOVE_MAX,
    BAND_EDGES,
    CLIPPED,
    NEAR_AXIS,
    NEGATIVE,
    OK,
    MaskingRules,
    masked_efficiency,
    shown_efficiency,
)
from fitting.map_honesty import honour_points, points_against_map
from fitting.point_uncertainty import efficiency_ceilings
from fitting.points import QUADRANTS, quadrant_of
from kernel.units import RPM_PER_RAD_S


def nice_step(raw: float) -> float:
    """The smallest of 1, 2, 2.5 and 5 times a power of ten that is not below ``raw`` (> 0)."""
    if not (np.isfinite(raw) and raw > 0):
        return 1.0
    exp = np.floor(np.log10(raw))
    for m in (1.0, 2.0, 2.5, 5.0, 10.0):
        step = m * 10.0**exp
        if step >= raw * (1 - 1e-12):
            return float(step)
    return float(10.0 ** (exp + 1))  # unreachable: m = 10 always fits


#: Default number of map grid steps over the measured speed range and torque range.
GRID_SPEED_STEPS, GRID_TORQUE_STEPS = 180, 80


def grid_steps(frame) -> tuple[float, float]:
    """Default map spacing [rpm], [N m]: ~180 steps over the speed range, ~80 over the torque range.

    Rounded up to 1, 2, 2.5 or 5 times a power of ten (25 rpm and 1 N m for a
    -3000..1500 rpm, 0..78 N m campaign), so the map has the same resolution
    for any drive size.
    """
    span_s = float(np.ptp(frame["speed_rpm"])) if len(frame) else 0.0
    span_t = float(np.max(np.abs(frame["torque_nm"]))) if len(frame) else 0.0
    return nice_step(span_s / GRID_SPEED_STEPS), nice_step(span_t / GRID_TORQUE_STEPS)


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
    speed_step_rpm: float | None = None,
    torque_step_nm: float | None = None,
) -> pd.DataFrame:
    """Efficiency map on a regular speed-torque grid (paper Fig. 5).

    Per quadrant: nodes outside the measured envelope (:func:`fitting.domain.
    quadrant_envelopes`) stay NaN (``outside_domain``); inside, the measured loss
    ``P_elec - P_mech`` is interpolated linearly over a Delaunay triangulation of
    the quadrant's points (in scaled coordinates), the node's electrical power is
    its exact ``omega * T`` plus that loss, and the efficiency follows by eqs. 1-2
    and the masking rules. An efficiency above the quadrant's ceiling
    (:func:`fitting.point_uncertainty.efficiency_ceilings`) is set to the ceiling and
    flagged ``clipped``.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w`` and ``quadrant``.
    rules : MaskingRules
    model : PowerModel, optional
        If given, adds the model's power and efficiency at each node (inside the domain).
    speed_step_rpm, torque_step_nm : float, optional
        Grid spacing [rpm], [N m]; default :func:`grid_steps`.

    Returns
    -------
    pandas.DataFrame
        One row per node: ``speed_rpm, torque_nm, quadrant, in_domain, p_mech_w,
        loss_w, p_elec_w, eta, status`` (and ``p_elec_fit_w, eta_fit`` with a model).
        ``attrs["envelopes"]`` and ``attrs["ceilings"]`` hold what the map used.
    """
    default_s, default_t = grid_steps(frame)
    speeds, torques = regular_grid(frame, speed_step_rpm or default_s, torque_step_nm or default_t)
    sg, tg = np.meshgrid(speeds, torques, indexing="ij")
    s, t = sg.ravel(), tg.ravel()
    envelopes = quadrant_envelopes(frame, rules.envelope_band_frac)
    ceilings = efficiency_ceilings(frame, rules)
    at = map_at(frame, rules, s, t, envelopes, ceilings)
    p_mech, quadrant = at["p_mech_w"], at["quadrant"]
    loss = honour_points(at["loss_w"].reshape(sg.shape), speeds, torques, quadrant.reshape(
        sg.shape), frame, rules, ceilings).ravel()
    eta, status = shown_efficiency(p_mech, quadrant, loss, rules, ceilings)
    in_domain = np.isfinite(loss)
    p_elec = p_mech + loss
    for q, ceiling in ceilings.items():
        ceiling["n_clipped_nodes"] = int(((quadrant == q) & (status == CLIPPED)).sum())
    out = pd.DataFrame({
        "speed_rpm": s, "torque_nm": t, "quadrant": quadrant, "in_domain": in_domain,
        "p_mech_w": p_mech, "loss_w": loss, "p_elec_w": p_elec, "eta": eta,
        "status": status.astype(str),
    })
    if model is not None:
        p_fit = np.asarray(model.p_elec_w(s, t), dtype=float)
        eta_fit, _ = masked_efficiency(p_mech, p_fit, rules)
        out["p_elec_fit_w"] = p_fit
        out["eta_fit"] = np.where(in_domain, eta_fit, np.nan)
    out.attrs["envelopes"] = envelopes
    out.attrs["ceilings"] = ceilings
    return out


def map_at(frame: pd.DataFrame, rules: MaskingRules, speed_rpm, torque_nm,
           envelopes: dict | None = None, ceilings: dict | None = None) -> dict[str, np.ndarray]:
    """The map's loss and efficiency at any speed-torque points (what :func:`gridded_map` draws).

    Per quadrant the measured loss ``P_elec - P_mech`` is interpolated linearly over
    a Delaunay triangulation of the quadrant's points (in coordinates scaled by the
    largest |speed| and torque), inside the quadrant's measured envelope only; the
    efficiency follows from the query's exact ``omega * T`` and that loss (eqs.
    1-2, masking rules), at most the quadrant's ceiling (``clipped``). At a measured
    point the interpolant is that point's own loss, so the map shows its efficiency,
    or the ceiling, which lies within its uncertainty
    (:func:`fitting.point_uncertainty.efficiency_ceilings`).

    Parameters
    ----------
    frame : pandas.DataFrame
        The measured points (``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w``,
        ``quadrant``).
    rules : MaskingRules
    speed_rpm, torque_nm : array_like
        Where to evaluate [rpm], [N m].
    envelopes, ceilings : dict, optional
        :func:`fitting.domain.quadrant_envelopes` and
        :func:`fitting.point_uncertainty.efficiency_ceilings` of
        ``frame`` (computed when not given).

    Returns
    -------
    dict
        ``p_mech_w``, ``quadrant``, ``loss_w`` (NaN outside the envelope), ``eta``
        and ``status`` (``outside_domain`` outside it) per query point.
    """
    s = np.asarray(speed_rpm, dtype=float).ravel()
    t = np.asarray(torque_nm, dtype=float).ravel()
    envelopes = (quadrant_envelopes(frame, rules.envelope_band_frac) if envelopes is None
                 else envelopes)
    ceilings = efficiency_ceilings(frame, rules) if ceilings is None else ceilings
    p_mech = s / RPM_PER_RAD_S * t
    quadrant = quadrant_of(p_mech)
    scales = (float(np.max(np.abs(frame["speed_rpm"]))) or 1.0,
              float(np.max(np.abs(frame["torque_nm"]))) or 1.0)
    loss = np.full(s.shape, np.nan)
    for q, env in envelopes.items():
        sub = frame[frame["quadrant"] == q]
        nodes = np.flatnonzero((quadrant == q) & in_polygon(env["polygon"], s, t))
        if nodes.size == 0:
            continue
        pts = np.column_stack([sub["speed_rpm"] / scales[0], sub["torque_nm"] / scales[1]])
        try:
            tri = Delaunay(pts)
        except QhullError:
            continue
        query = np.column_stack([s[nodes] / scales[0], t[nodes] / scales[1]])
        measured_loss = (sub["p_elec_w"] - sub["p_mech_w"]).to_numpy(dtype=float)
        loss[nodes] = _interpolate_in_hull(tri, measured_loss, query)
    eta, status = shown_efficiency(p_mech, quadrant, loss, rules, ceilings)
    return {"p_mech_w": p_mech, "quadrant": quadrant, "loss_w": loss, "eta": eta,
            "status": status}


def band_shares(map_frame: pd.DataFrame, edges=BAND_EDGES) -> pd.DataFrame:
    """Share of each quadrant's measured domain per efficiency band (regular grid: node share).

    Rows: quadrant x band, where the bands are the intervals of ``edges`` (``ok``
    and ``clipped`` nodes, by their shown efficiency) plus ``masked`` (near the
    axes or above max) and ``negative`` (set to 0).
    """
    rows = []
    for q in QUADRANTS:
        sub = map_frame[(map_frame["quadrant"] == q) & map_frame["in_domain"]]
        n = len(sub)
        if n == 0:
            continue
        ok = sub[sub["status"].isin((OK, CLIPPED))]["eta"].to_numpy()
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
    """Peak efficiency per quadrant: on the gridded map and among the measured points.

    ``map`` is the shown peak (``ok`` or ``clipped`` nodes; ``clipped`` says whether
    it sits on the ceiling), ``measured`` the highest ``ok`` point, and ``ceiling``
    the map's ceiling (``map_frame.attrs["ceilings"]``) when known.
    """
    eta_pts, status_pts = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    ceilings = map_frame.attrs.get("ceilings", {})
    out = {}
    for q in QUADRANTS:
        entry = {}
        grid = map_frame[(map_frame["quadrant"] == q)
                         & map_frame["status"].isin((OK, CLIPPED))]
        if len(grid):
            row = grid.loc[grid["eta"].idxmax()]
            entry["map"] = {"speed_rpm": float(row["speed_rpm"]),
                            "torque_nm": float(row["torque_nm"]), "eta": float(row["eta"]),
                            "clipped": bool(row["status"] == CLIPPED)}
        sel = (frame["quadrant"].to_numpy() == q) & (status_pts == OK)
        if sel.any():
            k = int(np.flatnonzero(sel)[np.argmax(eta_pts[sel])])
            entry["measured"] = {"speed_rpm": float(frame["speed_rpm"].iloc[k]),
                                 "torque_nm": float(frame["torque_nm"].iloc[k]),
                                 "eta": float(eta_pts[k])}
        if q in ceilings:
            c = ceilings[q]
            entry["ceiling"] = {"eta": c["eta"], "eta_max_measured": c["eta_max_measured"],
                                "noise_eta": c["noise_eta"], "u_p_elec_w": c["u_p_elec_w"],
                                "u_p_mech_w": c["u_p_mech_w"], "n_points": c["n_points"],
                                "n_clipped_nodes": c.get("n_clipped_nodes", 0)}
        if entry:
            out[q] = entry
    return out


def efficiency_summary(map_frame: pd.DataFrame, frame: pd.DataFrame, rules: MaskingRules,
                       loss_repeat: dict, repeats: dict, envelopes: dict) -> dict:
    """The fit summary's ``efficiency`` statement (docs/schemas.md section 4).

    Parameters
    ----------
    map_frame : pandas.DataFrame
        The map (:func:`gridded_map`).
    frame : pandas.DataFrame
        The points it was drawn from.
    rules : MaskingRules
    loss_repeat, repeats : dict
        :func:`fitting.repeatability.loss_repeatability` and
        :func:`fitting.repeatability.repeatability` of the points.
    envelopes : dict
        :func:`fitting.domain.quadrant_envelopes` of the points.

    Returns
    -------
    dict
        ``masking``, ``band_shares`` (records), ``peak``, ``points_against_map``,
        ``loss_repeatability``, ``repeatability`` and per quadrant ``envelope``.
    """
    return {"masking": rules.to_dict(),
            "band_shares": band_shares(map_frame).to_dict(orient="records"),
            "peak": peak_points(map_frame, frame, rules),
            "points_against_map": points_against_map(frame, rules, map_frame,
                                                     map_frame.attrs["ceilings"]),
            "loss_repeatability": loss_repeat,
            "repeatability": repeats,
            "envelope": {q: {"band_width_rpm": env["band_width_rpm"],
                             "n_points": env["n_points"],
                             "n_vertices": len(env["polygon"])}
                         for q, env in envelopes.items()}}
