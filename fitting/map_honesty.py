"""Reading the map's grid as a user reads it (bilinear between nodes), the correction that
makes that reading show every accepted point within its uncertainty, and the count of
points the shipped map does not honour."""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitting.efficiency import OK, MaskingRules, masked_efficiency, shown_efficiency
from fitting.point_uncertainty import float_column, loss_band, point_uncertainty


def _bilinear(speeds, torques, speed_rpm, torque_nm):
    """Flat node indices ``(n, 4)`` of the cell around each point and their bilinear weights."""
    s = np.asarray(speed_rpm, dtype=float)
    t = np.asarray(torque_nm, dtype=float)
    i = np.clip(np.searchsorted(speeds, s) - 1, 0, max(speeds.size - 2, 0))
    j = np.clip(np.searchsorted(torques, t) - 1, 0, max(torques.size - 2, 0))
    i1, j1 = np.minimum(i + 1, speeds.size - 1), np.minimum(j + 1, torques.size - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        fs = np.nan_to_num(np.clip((s - speeds[i]) / (speeds[i1] - speeds[i]), 0.0, 1.0))
        ft = np.nan_to_num(np.clip((t - torques[j]) / (torques[j1] - torques[j]), 0.0, 1.0))
    nt = torques.size
    idx = np.column_stack([i * nt + j, i1 * nt + j, i * nt + j1, i1 * nt + j1])
    w = np.column_stack([(1 - fs) * (1 - ft), fs * (1 - ft), (1 - fs) * ft, fs * ft])
    return idx, w


def read_grid(map_frame: pd.DataFrame, speed_rpm, torque_nm) -> np.ndarray:
    """The loss a user reads off ``efficiency_map.parquet`` at any points [W].

    Bilinear in the cell of nodes around each point, over its in-domain nodes only
    (their weights renormalised; NaN when none is in the domain).
    """
    speeds = np.unique(map_frame["speed_rpm"].to_numpy(dtype=float))
    torques = np.unique(map_frame["torque_nm"].to_numpy(dtype=float))
    grid = np.full(speeds.size * torques.size, np.nan)
    k = (np.searchsorted(speeds, map_frame["speed_rpm"].to_numpy(dtype=float)) * torques.size
         + np.searchsorted(torques, map_frame["torque_nm"].to_numpy(dtype=float)))
    grid[k] = map_frame["loss_w"].to_numpy(dtype=float)
    idx, w = _bilinear(speeds, torques, speed_rpm, torque_nm)
    v = grid[idx]
    w = np.where(np.isfinite(v) & (w > 0), w, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (w * np.nan_to_num(v)).sum(axis=1) / w.sum(axis=1)


#: iterations of the projection that makes the grid honour the points (each a few
#: vector operations over the points)
HONOUR_ITERATIONS = 400


def honour_points(loss: np.ndarray, speeds: np.ndarray, torques: np.ndarray,
                  node_quadrant: np.ndarray, frame: pd.DataFrame, rules: MaskingRules,
                  ceilings: dict) -> np.ndarray:
    """Correct the grid's node losses so that, read as a user reads it (:func:`read_grid`),
    the map shows every accepted point's efficiency within its uncertainty.

    The nodes sample the interpolant of the measured losses, which passes through
    each point; between nodes a reader interpolates bilinearly, and where the
    measured loss varies faster than the grid's step (a noisy point, repeats that
    differ) the reading at a point can differ from its loss by more than its
    uncertainty. Each such point's reading is projected onto its band
    (:func:`fitting.point_uncertainty.loss_band`, shrunk by 2 % against round-off) by moving
    its cell's
    in-domain nodes in proportion to their weights, simultaneously for all points,
    each node by the mean of the moves asked of it (Cimmino's method) and kept
    between the lowest and highest band end of the points it serves (and its own
    value), until every reading is in its band or :data:`HONOUR_ITERATIONS` pass.
    Where two points in one cell ask for disjoint bands (repeats that disagree
    beyond their uncertainty) no node values satisfy both; a last pass then lowers
    only the readings above a band's upper end, so that no point lies above the
    map by more than its uncertainty (the other lies below it: counted by
    :func:`points_against_map`). Nodes no point's cell touches are unchanged.

    Parameters
    ----------
    loss : numpy.ndarray
        Node losses [W], shape ``(speeds.size, torques.size)`` (NaN outside the domain).
    speeds, torques : numpy.ndarray
        The grid's node vectors [rpm], [N m].
    node_quadrant : numpy.ndarray
        Quadrant of each node, the shape of ``loss``.
    frame, rules, ceilings
        The points, the masking rules and
        :func:`fitting.point_uncertainty.efficiency_ceilings`: points the rules
        leave ``ok`` in a quadrant with a ceiling are honoured.

    Returns
    -------
    numpy.ndarray
        The corrected node losses, the shape of ``loss``.
    """
    out = loss.ravel().copy()
    _, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    quadrant = frame["quadrant"].to_numpy()
    sel = (status == OK) & np.isin(quadrant, list(ceilings))
    if not sel.any() or speeds.size < 2 or torques.size < 2:
        return out.reshape(loss.shape)
    idx, w = _bilinear(speeds, torques, frame["speed_rpm"].to_numpy()[sel],
                       frame["torque_nm"].to_numpy()[sel])
    w = np.where(np.isfinite(out[idx]) & (node_quadrant.ravel()[idx] == quadrant[sel][:, None])
                 & (w > 0), w, 0.0)
    covered = w.sum(axis=1) > 0
    idx, w = idx[covered], w[covered] / w.sum(axis=1)[covered][:, None]
    lo, hi = (x[sel][covered] for x in loss_band(frame, rules))
    target = (float_column(frame, "p_elec_w") - float_column(frame, "p_mech_w"))[sel][covered]
    lo, hi = target - 0.98 * (target - lo), target + 0.98 * (hi - target)
    return _project(out, idx, w, lo, hi).reshape(loss.shape)


def _project(out: np.ndarray, idx: np.ndarray, w: np.ndarray, lo: np.ndarray,
             hi: np.ndarray) -> np.ndarray:
    """Move the nodes ``out`` until each point's reading ``(w * out[idx]).sum(1)`` lies in
    ``[lo, hi]``: both ends first, then (when that does not settle) the upper end only."""
    # no node leaves the range of its own value and the bands of the points it serves:
    # a correction never shows an efficiency no nearby point allows
    touched = idx[w > 0]
    floor, cap = out.copy(), out.copy()
    np.minimum.at(floor, touched, np.broadcast_to(lo[:, None], w.shape)[w > 0])
    np.maximum.at(cap, touched, np.broadcast_to(hi[:, None], w.shape)[w > 0])
    for one_sided in (False, True):
        out, settled = _project_pass(out, idx, w, lo, hi, (floor, cap), one_sided)
        if settled:
            break
    return out


def _project_pass(out, idx, w, lo, hi, bounds, one_sided: bool) -> tuple[np.ndarray, bool]:
    """At most :data:`HONOUR_ITERATIONS` simultaneous projections (Cimmino's method);
    True when every reading is in its band (``one_sided``: at most its upper end)."""
    norm = (w**2).sum(axis=1)
    for _ in range(HONOUR_ITERATIONS):
        reading = (w * np.nan_to_num(out[idx])).sum(axis=1)
        move = np.where(reading > hi, hi - reading, 0.0)
        if not one_sided:
            move = np.where(reading < lo, lo - reading, move)
        if not move.any():
            return out, True
        step = w * (move / norm)[:, None]
        asked = w * (move != 0)[:, None] > 0
        total = np.bincount(idx.ravel(), step.ravel(), out.size)
        count = np.bincount(idx.ravel(), asked.ravel(), out.size)
        out = np.clip(out + np.where(count > 0, total / np.maximum(count, 1), 0.0), *bounds)
    return out, False


def points_against_map(frame: pd.DataFrame, rules: MaskingRules, map_frame: pd.DataFrame,
                       ceilings: dict) -> dict:
    """Per quadrant: do the accepted points lie on the map, as shipped, within their uncertainty?

    The map is read off its grid as a user reads it (:func:`read_grid`), its
    efficiency shown as :func:`fitting.efficiency_map.gridded_map` shows it (at most the ceiling).

    Returns ``quadrant -> {"n_points", "n_above_map", "max_excess", "n_below_map",
    "n_off_map"}``: the ``ok`` points, those whose efficiency exceeds the map's at
    that point by more than their uncertainty
    (:func:`fitting.point_uncertainty.point_uncertainty`), the
    largest such excess [-] (0 when none), those below the map by more than their
    uncertainty (where the map is optimistic: a repeat that measured a lower loss
    nearby), and the points no in-domain node surrounds.
    """
    eta, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    u = np.nan_to_num(point_uncertainty(frame, rules))
    p_mech = float_column(frame, "p_mech_w")
    quadrant = frame["quadrant"].to_numpy()
    loss = read_grid(map_frame, frame["speed_rpm"], frame["torque_nm"])
    shown, _ = shown_efficiency(p_mech, quadrant, loss, rules, ceilings)
    out = {}
    for q in ceilings:
        sel = (quadrant == q) & (status == OK)
        on = sel & np.isfinite(loss) & np.isfinite(shown)
        excess = np.where(on, eta - shown - u, -np.inf)
        below = np.where(on, shown - eta - u, -np.inf)
        out[q] = {"n_points": int(sel.sum()), "n_above_map": int((excess > 1e-12).sum()),
                  "max_excess": float(max(excess.max(initial=0.0), 0.0)),
                  "n_below_map": int((below > 1e-12).sum()),
                  "n_off_map": int((sel & ~on).sum())}
    return out
