"""The paper's extra-terms check: fitted over its space (speed^0..6 x torque^0..4), how big
are the terms beyond eq. 4, in the paper's scaling, at the rated corner, and in what
they change in the power?"""

from __future__ import annotations

import numpy as np

from fitting.power_fit import FitResult, fit_power_model, term_scale
from fitting.selection import paper_space_candidate
from fitting.terms import PAPER_TERMS, term_label


def _orders(big: float, small: float) -> float:
    """Orders of magnitude ``small`` lies below ``big`` (inf when ``small`` is 0)."""
    return float(np.log10(big / small)) if small > 0 else float("inf")


def _extra_term_rows(wide: FitResult, terms, contrib: np.ndarray, a1: float, a2: float,
                     a1_w: float, a2_w: float) -> list[dict]:
    """The wide fit's terms beyond eq. 4, largest contribution at the rated corner first."""
    rows = []
    for k in np.argsort(-contrib):
        t = terms[k]
        if t in PAPER_TERMS:
            continue
        c = abs(wide.coefficients_rpm[k])
        rows.append({
            "term": term_label(t),
            "coef_rpm": float(wide.coefficients_rpm[k]),
            "raw_orders_below_a1": _orders(a1, c),
            "raw_orders_below_a2": _orders(a2, c),
            "contribution_at_rated_w": float(contrib[k]),
            "rated_orders_below_a1": _orders(a1_w, contrib[k]),
            "rated_orders_below_a2": _orders(a2_w, contrib[k]),
        })
    return rows


def extra_terms_check(
    speed_rpm, torque_nm, p_elec_w, weights, *, rated_speed_rpm: float,
    rated_torque_nm: float, nominal_power_w: float, source=None,
) -> dict:
    """The paper's check: fitted over its space (w^6, T^4), how big are the extra terms?

    Three measures, each with its scaling stated in the result:

    - ``paper_scaling``: raw coefficients in the rpm convention divided by a1 and
      a2 of the eq. 4 fit, as the paper compares them (unit-dependent);
    - ``rated_corner``: a term's contribution ``|c_ij| * 1500**i * 78**j`` [W] at
      the rated corner, against ``a1 * 1500**2`` and ``a2 * 78**2`` of the eq. 4
      fit (physical, but individual terms of a 35-term fit are collinear and can
      cancel: see ``wide_fit_condition_number``);
    - ``model_difference``: the largest and RMS difference between the wide and
      the eq. 4 model over the measured points [W, % of nominal] (robust to the
      collinearity: it is what the extra terms change in the power).
    """
    speed = np.asarray(speed_rpm, dtype=float)
    torque = np.asarray(torque_nm, dtype=float)
    cand = paper_space_candidate()
    wide = fit_power_model(speed, torque, p_elec_w, cand.terms, weights=weights,
                           nominal_power_w=nominal_power_w, source=source)
    base = fit_power_model(speed, torque, p_elec_w, PAPER_TERMS, weights=weights,
                           nominal_power_w=nominal_power_w, source=source)
    a1 = abs(base.coefficients_rpm[PAPER_TERMS.index((2, 0))])
    a2 = abs(base.coefficients_rpm[PAPER_TERMS.index((0, 2))])
    a1_w, a2_w = a1 * rated_speed_rpm**2, a2 * rated_torque_nm**2
    contrib = np.abs(wide.coefficients_rpm) / term_scale(
        cand.terms, (rated_speed_rpm, rated_torque_nm))

    rows = _extra_term_rows(wide, cand.terms, contrib, a1, a2, a1_w, a2_w)
    named = {r["term"]: r for r in rows}
    diff = wide.residuals_w - base.residuals_w  # = eq.4 model - wide model at the points
    return {
        "space": cand.name,
        "paper_scaling": "raw rpm-convention coefficients vs a1, a2 of the eq. 4 fit "
                         "(as the paper compares them; unit-dependent)",
        "rated_scaling": f"|c_ij| * {rated_speed_rpm:g}^i * {rated_torque_nm:g}^j [W] vs "
                         f"a1 * {rated_speed_rpm:g}^2 = {a1_w:.1f} W and "
                         f"a2 * {rated_torque_nm:g}^2 = {a2_w:.1f} W",
        "a1_at_rated_w": float(a1_w),
        "a2_at_rated_w": float(a2_w),
        "wide_fit_condition_number": wide.condition_number,
        "paper_terms": {name: named[name] for name in ("w^2*T^2", "w^4")},
        "largest_extra_terms_at_rated": rows[:5],
        "model_difference": {
            "max_abs_w": float(np.max(np.abs(diff))),
            "rms_w": float(np.sqrt(np.mean(diff**2))),
            "max_abs_pct_nominal": float(100 * np.max(np.abs(diff)) / nominal_power_w),
        },
        "wide_fit_rmse_w": float(np.sqrt(np.mean(wide.residuals_w**2))),
        "eq4_fit_rmse_w": float(np.sqrt(np.mean(base.residuals_w**2))),
    }
