"""The report's power-model section: the Table I analogue with intervals, the power map
(paper Fig. 6), residuals and model selection (``bench fit``'s outputs, docs/schemas.md
§3, §4)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from fitting.fit_folder import MODEL_FILE, SELECTION_FILE, read_power_model, read_selection
from fitting.power_model import PowerModel
from kernel.thermal_model import ThermalModel
from optimize.door import paper_model
from reports import drive_figures
from reports.inputs import InputLog
from reports.tables import flatten, fmt, frame_table, missing_since, term_label

#: Two-sided 95 % normal quantile, used when the fit summary gives no intervals.
Z95 = 1.959963984540054


def read_model(log: InputLog, fit: Path) -> PowerModel | None:
    """The fitted power model ``fit/power_model.json`` (validated), or None if missing."""
    return log.read(fit, MODEL_FILE, read_power_model)


def power_model_section(log: InputLog, fit: Path, model: PowerModel | None,
                        points: pd.DataFrame | None, summary: dict | None) -> dict:
    """The power-model section: Table I analogue with intervals, Fig. 6, residuals, model selection.

    Parameters
    ----------
    log : InputLog
    fit : Path
        The ``bench fit`` output folder.
    model : PowerModel or None
        The fitted model (:func:`read_model`).
    points : DataFrame or None
        Store operating points; residuals are measured minus model at these.
    summary : dict or None
        ``fit_summary.json`` (its ``extra_terms_check``: the paper's claim that the
        largest higher-order terms are orders of magnitude below a1 and a2).

    Returns
    -------
    dict
        ``name``, ``coefficients`` rows, ``statistics`` (our residual figures),
        ``fit_statistics`` (as written by the fit), ``power_map``, ``residuals``,
        ``selection`` table, ``extra_terms``, ``missing``.
    """
    start = len(log.missing)
    lacking = [] if model is not None else [str(Path(fit) / "power_model.json")]
    if points is None:
        lacking.append("the store's points/*.parquet")
    selection = log.read(fit, SELECTION_FILE, read_selection)
    out = {"name": None, "coefficients": [], "interval_note": "", "statistics": [],
           "fit_statistics": [], "power_map": None, "residuals": None, "selection": None,
           "selection_note": None, "extra_terms": None, "thermal": None}
    if selection is not None:
        out["selection"] = frame_table(selection)
    out["extra_terms"] = extra_terms_rows((summary or {}).get("extra_terms_check"))
    chosen = ((model.statistics if model is not None else None) or {}).get("selection")
    if isinstance(chosen, dict):
        out["selection_note"] = flatten(chosen)
    if model is not None:
        out["name"] = model.name
        out["n_terms"] = len(model.terms)
        out["coefficients"], out["interval_note"] = coefficient_rows(model)
        out["fit_statistics"] = flatten(model.statistics or {})
        out["provenance"] = flatten(model.provenance or {})
        out["thermal"] = thermal_tables(model.thermal)
        if points is not None and len(points):
            measured = points["p_elec_w"].to_numpy(float)
            residual = measured - model.p_elec_w(points["speed_rpm"].to_numpy(float),
                                                 points["torque_nm"].to_numpy(float))
            out["statistics"] = residual_rows(residual, model.nominal_power_w)
            out["power_map"] = drive_figures.power_map_figure(model, points)
            out["residuals"] = drive_figures.residual_figure(points, residual,
                                                             model.nominal_power_w)
    out["missing"] = lacking + missing_since(log, start)
    return out


def thermal_tables(thermal: ThermalModel | None) -> dict | None:
    """The winding's thermal model (power_model.json ``thermal``) as two tables: its
    parameters with 95 % intervals, and the held-out check of each candidate network;
    None without a thermal model."""
    if thermal is None:
        return None

    def row(name, item, key, unit):
        lo, hi = item.ci95.get(key) or (math.nan, math.nan)
        return [name, fmt(getattr(item, key), sig=4), f"[{fmt(lo, sig=4)}, {fmt(hi, sig=4)}]",
                unit]
    rows = [row("steady resistance winding to ambient", thermal, "r_th_k_per_w", "K/W"),
            row("time constant (mean, with more nodes)", thermal, "tau_th_s", "s"),
            row("copper temperature coefficient", thermal, "copper_temp_coeff_per_k", "1/K")]
    for node in thermal.ladder or ():
        rows += [row(f"{node.node}: heat capacity", node, "c_j_per_k", "J/K"),
                 row(f"{node.node}: resistance outwards", node, "r_k_per_w", "K/W")]
    params = {"columns": ["parameter", "value", "95 % interval", "unit"], "rows": rows,
              "truncated": 0, "notes": []}
    selection = thermal.selection or {}
    check = {"columns": ["nodes", "held-out RMS [K]", "standard error [K]", "per part [K]"],
             "rows": [[str(c["nodes"]), fmt(c["cv_rms_k"], sig=3), fmt(c["cv_rms_k_se"], sig=3),
                       ", ".join(f"{k} {fmt(v, sig=3)}" for k, v in c["held_out_rms_k"].items())]
                      for c in selection.get("candidates", [])],
             "truncated": 0,
             "notes": [f"chosen: {thermal.node_count} node(s); rule: "
                       f"{selection.get('rule', 'none recorded (a model fitted with one node)')}"]
             + ([selection["note"]] if selection.get("note") else [])}
    return {"nodes": thermal.node_count, "parameters": params, "check": check}


def extra_terms_rows(check) -> dict | None:
    """The fit's check of the paper's largest extra terms (w^2*T^2, w^4) as a table, or None."""
    terms = check.get("paper_terms") if isinstance(check, dict) else None
    if not isinstance(terms, dict) or not terms:
        return None
    rows = [r for r in terms.values() if isinstance(r, dict)]
    columns = list(dict.fromkeys(k for r in rows for k in r))
    return {"columns": columns,
            "rows": [[fmt(r.get(c), sig=3) if isinstance(r.get(c), float) else str(r.get(c, ""))
                      for c in columns] for r in rows],
            "truncated": 0,
            "notes": [f"{k}: {v}" for k, v in check.items() if isinstance(v, str)]}


def coefficient_rows(model: PowerModel) -> tuple[list[dict], str]:
    """Table I analogue: one row per term with std error, 95 % interval and the paper's value.

    The interval is the fit's own (``statistics.coefficients`` of the model file,
    ``ci95_low_rpm``/``ci95_high_rpm``) when present, else ``c ± 1.96 sqrt(cov_kk)``
    (normal approximation) from the covariance. The paper value is shown where
    the term is one of eq. (4)'s (docs/paper_figures.md §1).

    Returns
    -------
    rows : list of dict
    interval_note : str
        Where the intervals come from.
    """
    paper = paper_model()
    paper_c = dict(zip(paper.terms, paper.coefficients_rpm, strict=True))
    names = {(0, 0): "a0", (2, 0): "a1", (0, 2): "a2", (1, 1): "a3"}
    cov = None if model.covariance_rpm is None else np.array(model.covariance_rpm)
    stated = {}
    for r in (model.statistics or {}).get("coefficients") or []:
        if isinstance(r, dict) and {"speed_exp", "torque_exp", "ci95_low_rpm",
                                    "ci95_high_rpm"} <= set(r):
            stated[(int(r["speed_exp"]), int(r["torque_exp"]))] = r
    use_stated = all(t in stated for t in model.terms)
    rows = []
    for k, (term, c) in enumerate(zip(model.terms, model.coefficients_rpm, strict=True)):
        se = math.sqrt(cov[k, k]) if cov is not None and cov[k, k] >= 0 else None
        if use_stated:
            lo, hi = stated[term]["ci95_low_rpm"], stated[term]["ci95_high_rpm"]
            se = stated[term].get("std_error_rpm", se)
        elif se is not None:
            lo, hi = c - Z95 * se, c + Z95 * se
        pc = paper_c.get(term)
        rows.append({
            "symbol": names.get(term, ""),
            "term": term_label(term),
            "coef": fmt(c, sig=6),
            "std_error": fmt(se, sig=3),
            "ci95": f"[{fmt(lo, sig=5)}, {fmt(hi, sig=5)}]" if se is not None or use_stated
            else "n/a (no covariance)",
            "paper": fmt(pc, sig=6) if pc is not None else "",
            "diff_pct": fmt(100.0 * (c - pc) / pc, 1) if pc else "",
            "coef_si": fmt(model.coefficients_si[k], sig=6),
        })
    note = ("95 % intervals as computed by the fit (power_model.json statistics.coefficients)"
            if use_stated else
            "95 % intervals: coefficient ± 1.96 standard errors from the covariance in "
            "power_model.json (normal approximation)")
    return rows, note


def residual_rows(residual_w: np.ndarray, nominal_power_w: float) -> list[dict]:
    """Residual mean, standard deviation and max |.| in W and % of nominal, with the paper's."""
    pct = 100.0 / nominal_power_w
    mean = float(np.mean(residual_w))
    sd = float(np.std(residual_w, ddof=1)) if residual_w.size > 1 else float("nan")
    mx = float(np.max(np.abs(residual_w)))
    return [
        {"name": "points", "value": str(residual_w.size), "pct": "", "paper": "> 1000"},
        {"name": "mean residual", "value": f"{mean:.1f} W", "pct": f"{mean * pct:.2f} %",
         "paper": "0 W"},
        {"name": "std of residual", "value": f"{sd:.1f} W", "pct": f"{sd * pct:.2f} %",
         "paper": "1.6 % of nominal"},
        {"name": "max |residual|", "value": f"{mx:.1f} W", "pct": f"{mx * pct:.2f} %",
         "paper": "< 5 % of nominal"},
    ]
