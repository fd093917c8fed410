"""Repeatability: how well the campaign's sessions repeat one operating point (pairs of
repeats, the pooled loss repeatability each point's uncertainty includes, and whether
the repeats agree within their uncertainty)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.spatial import cKDTree

from fitting.efficiency import OK, MaskingRules, masked_efficiency
from fitting.point_uncertainty import (
    REPEAT_COLUMN,
    float_column,
    point_uncertainty,
    power_uncertainty,
)

#: points of different sessions closer than this fraction of the largest |speed| and
#: torque are measurements of one operating point (a repeat) [-]
REPEAT_FRAC = 0.01


#: fewest pairs of repeats that estimate a loss repeatability (per quadrant, else pooled
#: over the campaign) [-]
MIN_REPEAT_PAIRS = 5


def repeat_pairs(frame: pd.DataFrame, rules: MaskingRules) -> tuple[np.ndarray, np.ndarray]:
    """Repeated measurements of one operating point: pairs ``(i, j)`` of row positions.

    Accepted (``ok``) points of one quadrant from different sessions that lie within
    :data:`REPEAT_FRAC` of the largest |speed| and torque of each other.
    """
    _, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    ok = np.flatnonzero(status == OK)
    if ok.size < 2:
        return np.zeros(0, int), np.zeros(0, int)
    scales = (float(np.max(np.abs(frame["speed_rpm"]))) or 1.0,
              float(np.max(np.abs(frame["torque_nm"]))) or 1.0)
    xy = np.column_stack([frame["speed_rpm"].to_numpy()[ok] / scales[0],
                          frame["torque_nm"].to_numpy()[ok] / scales[1]])
    pairs = cKDTree(xy).query_pairs(REPEAT_FRAC, p=np.inf, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    session = (frame["session_id"].to_numpy()[ok] if "session_id" in frame.columns
               else np.zeros(ok.size))
    quadrant = frame["quadrant"].to_numpy()[ok]
    i, j = pairs[:, 0], pairs[:, 1]
    keep = (session[i] != session[j]) & (quadrant[i] == quadrant[j])
    return ok[i[keep]], ok[j[keep]]


def loss_repeatability(frame: pd.DataFrame, rules: MaskingRules) -> dict:
    """How well the campaign's sessions repeat one operating point, as a loss [W].

    For each pair of repeats (:func:`repeat_pairs`) the losses ``L = P_elec - P_mech``
    differ by ``d``; the window statistics and the instruments' accuracy
    (:func:`fitting.point_uncertainty.power_uncertainty`) explain ``u_i**2 + u_j**2`` of
    ``d**2``. The
    repeatability is the pooled rest, per point::

        u_rep**2 = max(0, sum(d**2 - u_i**2 - u_j**2) / (2 n_pairs))

    (what a tare, a winding temperature or a fan that differs between sessions adds to
    one point's loss). It is pooled per quadrant when the quadrant has at least
    :data:`MIN_REPEAT_PAIRS` pairs, else over the campaign's pairs; with fewer (a
    campaign without repeated setpoints) it is 0: the fallback, said in a ``note``, so
    the points' uncertainty is their window statistics and instrument accuracy alone.

    Returns
    -------
    dict
        ``quadrant -> {"loss_w", "n_pairs", "pooled_over"}`` (``pooled_over``:
        ``quadrant``, ``campaign`` or ``none``) for each quadrant of ``frame``,
        ``rule``, and a ``note`` when the fallback applies.
    """
    i, j = repeat_pairs(frame, rules)
    loss = (float_column(frame, "p_elec_w") - float_column(frame, "p_mech_w"))
    u2 = sum(power_uncertainty(frame, p, rules.accuracy_frac) ** 2
             for p in ("p_elec", "p_mech"))
    excess = (loss[i] - loss[j]) ** 2 - u2[i] - u2[j]
    pair_q = frame["quadrant"].to_numpy()[i]

    def pooled(sel) -> float:
        return float(np.sqrt(max(0.0, np.sum(excess[sel]) / (2.0 * np.sum(sel)))))

    out: dict = {"rule": (
        "loss repeatability: pairs of accepted points of different sessions within "
        f"{REPEAT_FRAC:.0%} of the largest |speed| and torque; u_rep^2 = max(0, sum(d^2 - "
        "u_i^2 - u_j^2) / (2 n)) of their loss differences d beyond the window statistics "
        f"and instrument accuracy; per quadrant with >= {MIN_REPEAT_PAIRS} pairs, else "
        "pooled over the campaign, else 0 (no repeats)")}
    for q in dict.fromkeys(frame["quadrant"]):
        mine = pair_q == q
        if mine.sum() >= MIN_REPEAT_PAIRS:
            out[q] = {"loss_w": pooled(mine), "n_pairs": int(mine.sum()),
                      "pooled_over": "quadrant"}
        elif i.size >= MIN_REPEAT_PAIRS:
            out[q] = {"loss_w": pooled(np.ones(i.size, bool)), "n_pairs": int(i.size),
                      "pooled_over": "campaign"}
        else:
            out[q] = {"loss_w": 0.0, "n_pairs": int(mine.sum()), "pooled_over": "none"}
    if i.size < MIN_REPEAT_PAIRS:
        out["note"] = (
            f"repeatability not measured: {i.size} pair(s) of repeated operating points "
            f"across sessions (at least {MIN_REPEAT_PAIRS} needed); each point's uncertainty "
            "is its window statistics and instrument accuracy alone, which understates it "
            "when the sessions would not repeat")
    return out


def with_repeatability(frame: pd.DataFrame, repeat: dict) -> pd.DataFrame:
    """``frame`` with the column :data:`REPEAT_COLUMN`: each point's quadrant's loss
    repeatability [W] (:func:`loss_repeatability`)."""
    q = frame["quadrant"].to_numpy()
    values = np.array([repeat.get(k, {}).get("loss_w", 0.0) for k in q], dtype=float)
    return frame.assign(**{REPEAT_COLUMN: values})


def repeatability(frame: pd.DataFrame, rules: MaskingRules) -> dict:
    """Do repeated measurements of one operating point agree within their uncertainty?

    Pairs of repeats (:func:`repeat_pairs`); a pair disagrees when its efficiencies
    differ by more than twice their combined uncertainty: ``n_disagreeing_stated``
    with the window statistics and instrument accuracy alone, ``n_disagreeing`` with
    the loss repeatability too (:func:`fitting.point_uncertainty.point_uncertainty`, which reads
    :data:`REPEAT_COLUMN` when ``frame`` has it).

    Returns
    -------
    dict
        ``n_pairs``, ``n_disagreeing``, ``n_disagreeing_stated``,
        ``median_abs_diff_eta``, ``median_u_eta`` (with the repeatability; NaN without
        pairs), and a ``note`` when more than half of at least 5 pairs disagree.
    """
    eta, _ = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    u = point_uncertainty(frame, rules)
    u_stated = point_uncertainty(frame.drop(columns=REPEAT_COLUMN, errors="ignore"), rules)
    i, j = repeat_pairs(frame, rules)
    diff = np.abs(eta[i] - eta[j])
    combined = np.hypot(u[i], u[j])
    bad = diff > 2.0 * combined
    out = {"n_pairs": int(i.size), "n_disagreeing": int(bad.sum()),
           "n_disagreeing_stated": int((diff > 2.0 * np.hypot(u_stated[i], u_stated[j])).sum()),
           "median_abs_diff_eta": float(np.median(diff)) if i.size else float("nan"),
           "median_u_eta": float(np.median(combined)) if i.size else float("nan")}
    if i.size >= 5 and bad.sum() > 0.5 * i.size:
        out["note"] = (
            f"repeated operating points disagree: {int(bad.sum())} of {i.size} pairs of points "
            f"of different sessions within {REPEAT_FRAC:.0%} of the speed and torque range "
            f"differ by more than twice their uncertainty (median |d eta| "
            f"{out['median_abs_diff_eta']:.3g} against {out['median_u_eta']:.3g}): the "
            "sessions do not repeat within the instruments' accuracy (tare, temperature, a "
            "fault)")
    return out
