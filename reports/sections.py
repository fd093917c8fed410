"""The report's drive sections: one function per section, files in, plain context dict out.

Each function reads what its section needs through an :class:`reports.inputs.InputLog`
and returns a dict for the template. Every dict has ``missing``: the input files that
were absent, which the template states ("not available: <file> missing"). Strings
from logs and metadata stay plain strings here; the template escapes them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from bench.store.damage import check_store
from bench.store.manifest import kind_files as store_files
from bench.store.manifest import read_manifest
from fitting import figures
from fitting.model_schema import power_model_from_dict
from fitting.power_model import PowerModel
from kernel.errors import InputError
from optimize.paper_model import paper_model
from reports import drive_figures
from reports.inputs import InputLog
from reports.tables import fmt, frame_table, term_label

POINT_COLUMNS = ("session_id", "quadrant", "speed_rpm", "torque_nm", "p_mech_w", "p_elec_w")
REJECTED_COLUMNS = ("session_id", "t_start_s", "t_end_s", "reason")
EFFICIENCY_COLUMNS = ("speed_rpm", "torque_nm", "eta")
#: Two-sided 95 % normal quantile, used when the fit summary gives no intervals.
Z95 = 1.959963984540054


def _missing_since(log: InputLog, start: int) -> list[str]:
    return list(dict.fromkeys(log.missing[start:]))


def _store_kind(log: InputLog, store: Path, kind: str, manifest: dict | None,
                required: tuple[str, ...]) -> pd.DataFrame | None:
    """The ``kind`` files the store's manifest lists (never files it does not list)."""
    try:
        store_manifest = None if manifest is None else read_manifest(store)
    except InputError:  # not a store manifest: the campaign section says what is missing
        store_manifest = None
    files = [] if store_manifest is None else list(store_files(store, kind).values())
    if files:
        damage = check_store(store, store_manifest)
        if damage.damaged:
            raise InputError(store, "damaged store: " + "; ".join(damage.lines()[:3]),
                             expected="run bench store check, then bench ingest of the "
                                      "damaged sessions' folders")
    return log.parquet_files(files, str(Path(store) / kind / "*.parquet"), required)


def campaign_section(log: InputLog, store: Path) -> dict:
    """Section 1: sessions, instruments and metadata, points per quadrant, rejections, clocks.

    Parameters
    ----------
    log : InputLog
        Records the files read.
    store : Path
        The ``bench ingest`` store folder.

    Returns
    -------
    dict
        ``sessions`` (one dict per session), ``totals``, ``rejected_reasons``,
        ``figure``, ``missing``; and for the other sections ``points`` (the
        store's operating points or None) and ``manifest`` (decoded or None).
    """
    start = len(log.missing)
    store = Path(store)
    manifest = log.json(store / "manifest.json")
    points = _store_kind(log, store, "points", manifest, POINT_COLUMNS)
    rejected = _store_kind(log, store, "rejected", manifest, REJECTED_COLUMNS)
    sessions = []
    if manifest is not None:
        entries = manifest.get("sessions")
        if not isinstance(entries, dict):
            raise InputError(store / "manifest.json", "field 'sessions' is not an object",
                             expected="{session_id: {...}}")
        for sid, entry in sorted(entries.items()):
            sessions.append(_session_row(str(sid), entry if isinstance(entry, dict) else {}))
    quadrant_counts = {"motor": 0, "generator": 0}
    figure = None
    if points is not None and len(points):
        counts = points["quadrant"].astype(str).value_counts()
        quadrant_counts = {q: int(counts.get(q, 0)) for q in ("motor", "generator")}
        figure = drive_figures.operating_points_figure(points)
    reasons = []
    if rejected is not None and len(rejected):
        table = rejected.groupby("reason").size().sort_values(ascending=False)
        reasons = [{"reason": str(r), "count": int(n)} for r, n in table.items()]
    elif manifest is not None:
        agg: dict[str, int] = {}
        for entry in manifest["sessions"].values():
            for r, n in ((entry.get("rejected") if isinstance(entry, dict) else None)
                         or {}).items():
                agg[str(r)] = agg.get(str(r), 0) + int(n)
        reasons = [{"reason": r, "count": n} for r, n in sorted(agg.items(), key=lambda x: -x[1])]
    return {
        "sessions": sessions,
        "totals": {
            "sessions": len(sessions),
            "points": int(len(points)) if points is not None else None,
            **quadrant_counts,
            "rejected": sum(r["count"] for r in reasons),
        },
        "rejected_reasons": reasons,
        "figure": figure,
        "missing": _missing_since(log, start),
        "points": points,
        "manifest": manifest,
    }


def _session_row(sid: str, entry: dict) -> dict:
    meta = entry.get("metadata") if isinstance(entry.get("metadata"), dict) else {}
    ppq = entry.get("points_per_quadrant") or {}
    rejected = entry.get("rejected") or {}
    return {
        "session_id": sid,
        "kind": entry.get("kind", meta.get("kind", "")),
        "mode": entry.get("mode", meta.get("mode", "")),
        "operator": meta.get("operator", ""),
        "date": meta.get("date", ""),
        "n_points": entry.get("n_points"),
        "motor": ppq.get("motor"),
        "generator": ppq.get("generator"),
        "rejected": ", ".join(f"{k}: {v}" for k, v in sorted(rejected.items())),
        "no_points_note": entry.get("no_points_note", ""),
        "clock_offset_s": fmt(entry.get("clock_offset_s"), 3),
        "clock_drift_ppm": fmt(entry.get("clock_drift_ppm"), 1),
        "clock_offset_prior_s": fmt(entry.get("clock_offset_prior_s"), 3),
        "clock_correlation": fmt(entry.get("clock_correlation"), 3),
        "instruments": _instruments(
            meta, entry["instruments"] if isinstance(entry.get("instruments"), dict) else {}),
        "metadata": _flatten(meta),
    }


def _instruments(meta: dict, instruments: dict) -> list[dict]:
    """The session's instruments, one dict per stream (``stream, file, format, details``).

    ``instruments`` is what ingest recorded about each stream (the analyzer's
    header block, the column mapping); ``meta`` is the session.toml (files,
    sensor ranges, measured side).
    """
    rows = []
    for block in ("daq", "analyzer", "log", "points"):
        b = meta.get(block) if isinstance(meta.get(block), dict) else {}
        seen = instruments.get(block) if isinstance(instruments.get(block), dict) else {}
        if not (b or seen):
            continue
        header = seen.get("header") if isinstance(seen.get("header"), dict) else {}
        details = [f"{k} {header[k]}" for k in ("Model", "Serial", "Sample Interval", "Wiring")
                   if k in header]
        columns = seen.get("columns") if isinstance(seen.get("columns"), dict) else {}
        names = [str(c.get("column")) for c in columns.values() if isinstance(c, dict)]
        if names:
            details.append("columns: " + ", ".join(names))
        rows.append({"stream": block, "file": str(b.get("file", "")),
                     "format": str(seen.get("format", b.get("format", ""))),
                     "details": "; ".join(details)})
    sensors = meta.get("sensors")
    side = meta.get("measured_side")
    ranges = [f"{k} = {v}" for k, v in sensors.items()] if isinstance(sensors, dict) else []
    if side:
        ranges.append(f"measured side: {side}, gear ratio {meta.get('gear_ratio', '?')}")
    if ranges:
        rows.append({"stream": "sensors", "file": "", "format": "", "details": ", ".join(ranges)})
    return rows


def _flatten(data: dict, prefix: str = "") -> list[tuple[str, str]]:
    """Nested dict as (dotted key, text) pairs; lists of records are skipped (own tables)."""
    out = []
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.extend(_flatten(value, name + "."))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            continue
        else:
            out.append((name, fmt(value) if isinstance(value, float) else str(value)))
    return out


def read_model(log: InputLog, fit: Path) -> PowerModel | None:
    """The fitted power model ``fit/power_model.json`` (validated), or None if missing."""
    path = Path(fit) / "power_model.json"
    data = log.json(path)
    return None if data is None else power_model_from_dict(data, path)


def efficiency_section(log: InputLog, fit: Path, model: PowerModel | None,
                       summary: dict | None) -> dict:
    """Section 2: the efficiency map (paper Fig. 5) and its masking rules.

    Parameters
    ----------
    log : InputLog
    fit : Path
        The ``bench fit`` output folder (``efficiency_map.parquet``).
    model : PowerModel or None
        The fitted model; its ``masking`` holds the rules the map was made with.
    summary : dict or None
        ``fit_summary.json`` (band shares and peak points under ``efficiency``).

    Returns
    -------
    dict
        ``figure``, ``grid`` (for Fig. 9), ``masking`` (settings), ``rules``,
        ``bands``, ``peaks``, ``missing``.
    """
    start = len(log.missing)
    emap = log.parquet(Path(fit) / "efficiency_map.parquet", EFFICIENCY_COLUMNS)
    figure = grid = None
    if emap is not None and len(emap):
        grid = figures.efficiency_grid(emap)
        figure = drive_figures.efficiency_map_figure(
            emap, model.domain if model is not None else None)
    eff = (summary or {}).get("efficiency") or {}
    masking = dict((model.masking if model is not None else None) or eff.get("masking") or {})
    rules = [str(r) for r in masking.pop("rules", []) or []]
    return {
        "figure": figure,
        "grid": grid,
        "masking": _flatten(masking),
        "rules": rules,
        "notes": efficiency_notes(model, summary),
        "bands": band_table(eff.get("band_shares") or []),
        "peaks": peak_rows(eff.get("peak") or {}),
        "missing": _missing_since(log, start),
    }


def efficiency_notes(model: PowerModel | None, summary: dict | None) -> list[str]:
    """Lines about what the map and model stand on: drive rating, quadrants, ceilings."""
    notes = []
    drive = (model.drive if model is not None else None) or (summary or {}).get("drive")
    if isinstance(drive, dict) and {"nominal_power_w", "max_speed_rpm",
                                    "max_torque_nm"} <= set(drive):
        notes.append(f"Drive rating: {fmt(drive['nominal_power_w'], 0)} W nominal, |speed| <= "
                     f"{fmt(drive['max_speed_rpm'], 0)} rpm, torque <= "
                     f"{fmt(drive['max_torque_nm'], 1)} N m ({drive.get('source', '')}).")
    notes += [str(n) for n in (summary or {}).get("notes") or []]
    for q, entry in (((summary or {}).get("efficiency") or {}).get("peak") or {}).items():
        c = (entry or {}).get("ceiling")
        if isinstance(c, dict) and c.get("eta") is not None:
            clipped = c.get("n_clipped_nodes") or 0
            notes.append(f"{q}: no map node shows an efficiency above {fmt(c['eta'], 3)} (the "
                         f"highest measured {fmt(c.get('eta_max_measured'), 3)} plus its "
                         "uncertainty "
                         f"{fmt(c.get('noise_eta'), 3)})"
                         + (f"; {clipped} nodes were clipped to it." if clipped else "."))
    return notes


def band_table(records: list) -> dict | None:
    """Area share [%] per efficiency band (rows) and quadrant (columns), or None."""
    rows = [r for r in records if isinstance(r, dict) and {"quadrant", "band", "area_share"}
            <= set(r)]
    if not rows:
        return None
    quadrants = list(dict.fromkeys(str(r["quadrant"]) for r in rows))
    bands = list(dict.fromkeys(str(r["band"]) for r in rows))
    share = {(str(r["quadrant"]), str(r["band"])): r["area_share"] for r in rows}
    return {
        "columns": ["band", *quadrants],
        "rows": [[b, *(fmt(100.0 * share[(q, b)], 1) + " %" if (q, b) in share else ""
                       for q in quadrants)] for b in bands],
        "truncated": 0,
    }


def peak_rows(peaks: dict) -> list[dict]:
    """Peak-efficiency points per quadrant, on the gridded map and among measured points."""
    rows = []
    for quadrant, entry in peaks.items():
        for where, p in (entry or {}).items():
            if isinstance(p, dict) and where != "ceiling":
                rows.append({"quadrant": str(quadrant), "where": str(where),
                             "speed_rpm": fmt(p.get("speed_rpm"), 0),
                             "torque_nm": fmt(p.get("torque_nm"), 1),
                             "eta": fmt(p.get("eta"), 3)})
    return rows


def power_model_section(log: InputLog, fit: Path, model: PowerModel | None,
                        points: pd.DataFrame | None, summary: dict | None) -> dict:
    """Section 3: Table I analogue with intervals, Fig. 6, residuals, model selection.

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
    selection = log.parquet(Path(fit) / "selection.parquet")
    out = {"name": None, "coefficients": [], "interval_note": "", "statistics": [],
           "fit_statistics": [], "power_map": None, "residuals": None, "selection": None,
           "selection_note": None, "extra_terms": None}
    if selection is not None:
        out["selection"] = frame_table(selection)
    out["extra_terms"] = extra_terms_rows((summary or {}).get("extra_terms_check"))
    chosen = ((model.statistics if model is not None else None) or {}).get("selection")
    if isinstance(chosen, dict):
        out["selection_note"] = _flatten(chosen)
    if model is not None:
        out["name"] = model.name
        out["n_terms"] = len(model.terms)
        out["coefficients"], out["interval_note"] = coefficient_rows(model)
        out["fit_statistics"] = _flatten(model.statistics or {})
        out["provenance"] = _flatten(model.provenance or {})
        if points is not None and len(points):
            measured = points["p_elec_w"].to_numpy(float)
            residual = measured - model.p_elec_w(points["speed_rpm"].to_numpy(float),
                                                 points["torque_nm"].to_numpy(float))
            out["statistics"] = residual_rows(residual, model.nominal_power_w)
            out["power_map"] = drive_figures.power_map_figure(model, points)
            out["residuals"] = drive_figures.residual_figure(points, residual,
                                                             model.nominal_power_w)
    out["missing"] = lacking + _missing_since(log, start)
    return out


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
