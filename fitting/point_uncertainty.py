"""Each point's uncertainty: of its mean powers (window statistics, instrument accuracy),
of its efficiency (with the campaign's loss repeatability), the losses that show it
within that uncertainty, and the map's efficiency ceiling that follows."""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitting.efficiency import OK, MaskingRules, masked_efficiency, raw_efficiency
from fitting.points import QUADRANTS

#: per-point column of the loss repeatability [W] (:func:`fitting.repeatability.loss_repeatability`)
REPEAT_COLUMN = "loss_repeatability_w"


def float_column(frame: pd.DataFrame, name: str) -> np.ndarray:
    """A float column of ``frame``, or NaN throughout when it has none."""
    if name in frame.columns:
        return pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=float)
    return np.full(len(frame), np.nan)


def power_uncertainty(frame: pd.DataFrame, power: str, accuracy_frac: float) -> np.ndarray:
    """Standard uncertainty of each point's mean power [W] (``power``: ``p_elec``/``p_mech``).

    The standard error of the window mean, ``<power>_w_std / sqrt(n_samples)``
    (the std alone when the point states no sample count, as a table with a std
    column but no count; 0 when it states no std), and ``accuracy_frac`` of the
    reading (the instruments' accuracy), added in quadrature.
    """
    value = np.abs(float_column(frame, f"{power}_w"))
    std = float_column(frame, f"{power}_w_std")
    n = float_column(frame, "n_samples")
    with np.errstate(invalid="ignore", divide="ignore"):
        stat = np.where(np.isfinite(n) & (n > 0), std / np.sqrt(n), std)
    stat = np.where(np.isfinite(stat), stat, 0.0)
    return np.hypot(stat, accuracy_frac * value)


def point_uncertainty(frame: pd.DataFrame, rules: MaskingRules) -> np.ndarray:
    """Standard uncertainty of each point's efficiency (paper eqs. 1-2) [-].

    Both equations are a ratio of the two powers, so the relative uncertainties
    of ``P_elec`` and ``P_mech`` (:func:`power_uncertainty`) add in quadrature:
    ``u_eta = |eta| * sqrt((u_Pe / P_e)**2 + (u_Pm / P_m)**2 + (u_rep / P_e)**2)``;
    NaN where a power is 0. ``u_rep`` is the point's loss repeatability
    (column :data:`REPEAT_COLUMN` [W], 0 when absent;
    :func:`fitting.repeatability.loss_repeatability`):
    a loss error ``dL`` at the point's exact ``P_mech`` changes eta by
    ``eta * dL / |P_e|`` in both quadrants.
    """
    eta = raw_efficiency(frame["p_mech_w"], frame["p_elec_w"])
    rel = []
    for power in ("p_elec", "p_mech"):
        u = power_uncertainty(frame, power, rules.accuracy_frac)
        with np.errstate(invalid="ignore", divide="ignore"):
            rel.append(u / np.abs(float_column(frame, f"{power}_w")))
    repeat = np.nan_to_num(float_column(frame, REPEAT_COLUMN))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel.append(repeat / np.abs(float_column(frame, "p_elec_w")))
    return np.abs(eta) * np.sqrt(sum(r**2 for r in rel))


def loss_band(frame: pd.DataFrame, rules: MaskingRules) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the losses [W] at which the map shows its efficiency -/+ its uncertainty.

    ``lo`` is the loss of ``eta + u`` and ``hi`` that of ``eta - u`` at the point's exact
    ``P_mech`` (paper eqs. 1-2 solved for the loss; :func:`point_uncertainty`): a map
    loss within ``[lo, hi]`` shows the point's efficiency within its uncertainty.
    """
    p_mech = float_column(frame, "p_mech_w")
    eta = raw_efficiency(p_mech, float_column(frame, "p_elec_w"))
    u = np.nan_to_num(point_uncertainty(frame, rules))
    with np.errstate(invalid="ignore", divide="ignore"):
        motor = p_mech > 0
        lo = np.where(motor, p_mech / (eta + u) - p_mech, (1.0 - eta - u) * np.abs(p_mech))
        hi = np.where(motor, np.where(eta - u > 0, p_mech / (eta - u) - p_mech, np.inf),
                      (1.0 - eta + u) * np.abs(p_mech))
    return lo, hi


def efficiency_ceilings(frame: pd.DataFrame, rules: MaskingRules) -> dict[str, dict]:
    """The highest efficiency the map may show per quadrant: measured maximum plus its
    uncertainty.

    The maximum is taken over every point the masking rules leave ``ok`` (none is
    left out for being noisy, so the ceiling is never below an accepted point);
    the ceiling is that maximum plus that point's own standard uncertainty
    (:func:`point_uncertainty`), at most ``rules.max_efficiency``.

    Parameters
    ----------
    frame : pandas.DataFrame
        Points with ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w``, ``quadrant``
        and, when known, ``p_elec_w_std``, ``p_mech_w_std``, ``n_samples``.
    rules : MaskingRules
        Only points the rules leave ``ok`` count as measured efficiencies.

    Returns
    -------
    dict
        ``quadrant -> {"eta": ceiling, "eta_max_measured", "noise_eta",
        "u_p_elec_w", "u_p_mech_w", "n_points", "speed_rpm", "torque_nm"}`` (the
        uncertainties and the place are those of the highest point), for each
        quadrant with at least one ``ok`` point.
    """
    eta, status = masked_efficiency(frame["p_mech_w"], frame["p_elec_w"], rules)
    u_eta = point_uncertainty(frame, rules)
    u_pe = power_uncertainty(frame, "p_elec", rules.accuracy_frac)
    u_pm = power_uncertainty(frame, "p_mech", rules.accuracy_frac)
    quadrant = frame["quadrant"].to_numpy()
    out = {}
    for q in QUADRANTS:
        sel = np.flatnonzero((quadrant == q) & (status == OK))
        if sel.size == 0:
            continue
        k = int(sel[np.argmax(eta[sel])])
        noise = float(u_eta[k]) if np.isfinite(u_eta[k]) else 0.0
        out[q] = {"eta": float(min(eta[k] + noise, rules.max_efficiency)),
                  "eta_max_measured": float(eta[k]), "noise_eta": noise,
                  "u_p_elec_w": float(u_pe[k]), "u_p_mech_w": float(u_pm[k]),
                  "n_points": int(sel.size),
                  "speed_rpm": float(frame["speed_rpm"].iloc[k]),
                  "torque_nm": float(frame["torque_nm"].iloc[k])}
    return out
