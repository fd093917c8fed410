"""The report's efficiency section: the measured efficiency map (paper Fig. 5), its masking
rules, the area per efficiency band and the peak points (``bench fit``'s outputs,
docs/schemas.md §4)."""

from __future__ import annotations

from pathlib import Path

from fitting.fit_folder import MAP_FILE, read_efficiency_map
from fitting.power_model import PowerModel
from kernel.drive import Drive, dict_problem
from reports import drive_figures
from reports.inputs import InputLog
from reports.tables import flatten, fmt, missing_since


def efficiency_section(log: InputLog, fit: Path, model: PowerModel | None,
                       summary: dict | None) -> dict:
    """The efficiency section: the efficiency map (paper Fig. 5) and its masking rules.

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
        ``figure``, ``map`` (the map frame and domain, for Fig. 9; None without a map),
        ``masking`` (settings), ``rules``, ``bands``, ``peaks``, ``missing``.
    """
    start = len(log.missing)
    emap = log.read(fit, MAP_FILE, read_efficiency_map)
    figure = drawn = None
    if emap is not None and len(emap):
        drawn = {"map_frame": emap, "domain": model.domain if model is not None else None}
        figure = drive_figures.efficiency_map_figure(**drawn)
    eff = (summary or {}).get("efficiency") or {}
    masking = dict((model.masking if model is not None else None) or eff.get("masking") or {})
    rules = [str(r) for r in masking.pop("rules", []) or []]
    return {
        "figure": figure,
        "map": drawn,
        "masking": flatten(masking),
        "rules": rules,
        "notes": efficiency_notes(model, summary),
        "bands": band_table(eff.get("band_shares") or []),
        "peaks": peak_rows(eff.get("peak") or {}),
        "missing": missing_since(log, start),
    }


def fit_drive(model: PowerModel | None, summary: dict | None) -> Drive | None:
    """The fit's drive rating: the model's, else its summary's (``drive``); None when neither
    states a complete one."""
    if model is not None and model.drive is not None:
        return model.drive
    data = (summary or {}).get("drive")
    if not isinstance(data, dict) or dict_problem(data) is not None:
        return None
    return Drive.from_dict(data, rating=True)


def efficiency_notes(model: PowerModel | None, summary: dict | None) -> list[str]:
    """Lines about what the map and model stand on: drive rating, quadrants, ceilings."""
    notes = []
    drive = fit_drive(model, summary)
    if drive is not None:
        speed, torque = drive.box()
        notes.append(f"Drive rating: {fmt(drive.nominal_power_w, 0)} W nominal, |speed| <= "
                     f"{fmt(speed, 0)} rpm, torque <= {fmt(torque, 1)} N m "
                     f"({drive.source or ''}).")
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
