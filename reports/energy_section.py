"""The report's energy section: power curves with bands, AEP per scenario kind, losses, sizing.

Reads ``aep_out/aep.json``, ``aep_out/power_curves.csv`` and ``size_out/sizing.json``
(docs/schemas.md §7) through the :class:`reports.inputs.InputLog`; every missing file
is listed in ``missing`` and the template says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from markupsafe import Markup

from energy import plots
from energy.outputs import AEP_FILE, CURVES_FILE, cut_in_text, read_aep, read_power_curves
from energy.refine import refine_notes
from energy.sizing import limits_text
from energy.sizing_files import SIZING_FILE, read_sizing
from optimize.door import LABELS
from reports import svg
from reports.inputs import InputLog
from reports.tables import fmt


def power_curve_figure(curves: pd.DataFrame) -> Markup:
    """The power curves with bands (:func:`energy.plots.plot_power_curves`)."""
    fig = svg.new_figure(7.0, 4.2)
    plots.plot_power_curves(curves, fig.add_subplot())
    return svg.to_svg(fig, "energy-power-curves")


def aep_figure(table: pd.DataFrame) -> Markup:
    """AEP per scenario kind with bands (:func:`energy.plots.plot_aep`)."""
    fig = svg.new_figure(6.4, 3.6)
    plots.plot_aep(table, fig.add_subplot())
    return svg.to_svg(fig, "energy-aep")


def sizing_figure(candidates: list[dict], chosen: str | None) -> object:
    """Electrical AEP against the drive's rated torque, the chosen drive marked."""
    pts = [c for c in candidates if c.get("aep_elec_mwh") is not None]
    fig = svg.new_figure(6.0, 3.6)
    ax = fig.add_subplot()
    x = [c["rated_torque_nm"] for c in pts]
    y = [c["aep_elec_mwh"] for c in pts]
    ax.plot(x, y, "o-", color="#1f77b4")
    for c in pts:
        if c["candidate"] == chosen:
            ax.plot([c["rated_torque_nm"]], [c["aep_elec_mwh"]], "s", ms=11, mfc="none",
                    color="#d62728", label="chosen: smallest within tolerance of the best")
    ax.set_xlabel("rated (RMS) drum torque [N m]")
    ax.set_ylabel("electrical AEP [MWh/yr]")
    ax.grid(alpha=0.3)
    if chosen:
        ax.legend(fontsize=7)
    return svg.to_svg(fig, "energy-sizing")


def energy_section(log: InputLog, aep: Path, size: Path) -> dict:
    """The energy section's context: AEP, bands, losses, sizing.

    Returns
    -------
    dict
        ``site``, ``nominal``, ``table`` (rows of strings), ``losses``, ``warnings`` and
        ``notes`` (aep.json's notes: what may be wrong, and what is only said, such as the
        refinement), ``figure``, ``aep_figure``, ``sizing`` (or None), ``missing``,
        ``not_run``, ``documents`` (``aep.json`` and ``sizing.json`` decoded, or None).
    """
    start = len(log.missing)
    # optional stages: a folder that does not exist means the stage was not run (said in
    # ``not_run``); a folder without its files is a missing input
    not_run = [f"bench {name} (no {folder})" for name, folder in (("aep", aep), ("size", size))
               if not Path(folder).is_dir()]
    doc = log.read(aep, AEP_FILE, read_aep) if Path(aep).is_dir() else None
    curves = log.read(aep, CURVES_FILE, read_power_curves) if doc is not None else None
    out = aep_context(doc, curves) if doc is not None else {
        "site": None, "nominal": None, "table": [], "losses": [], "notes": [], "warnings": [],
        "figure": None, "aep_figure": None, "sign": None, "interpolation": None}
    sizing = log.read(size, SIZING_FILE, read_sizing) if Path(size).is_dir() else None
    out["sizing"] = sizing_context(sizing, doc) if sizing is not None else None
    if out["sizing"] is not None and doc is not None:
        out["sizing"]["grids"] = grid_difference(doc, curves, sizing)
    out["missing"] = list(dict.fromkeys(log.missing[start:]))
    out["not_run"] = not_run
    out["documents"] = {"aep": doc, "size": sizing}
    return out


def aep_context(doc: dict, curves: pd.DataFrame | None) -> dict:
    """The AEP part of the section from ``aep.json`` and ``power_curves.csv``."""
    site = doc.get("site") or {}
    rows = [r for r in doc.get("kinds") or [] if isinstance(r, dict)]
    informational = set(refine_notes(doc["refine"])) if isinstance(doc.get("refine"),
                                                                   dict) else set()
    notes = [str(n) for n in doc.get("notes") or []]
    out = {"site": site.get("note"),
           "nominal": f"{fmt(doc.get('nominal_power_w'), 0)} W ({doc.get('nominal_power_source')})",
           "sign": doc.get("sign_convention"), "interpolation": doc.get("interpolation"),
           "table": [aep_row(r) for r in rows],
           "losses": loss_rows(doc.get("losses") or {}),
           "notes": [n for n in notes if n in informational],
           "warnings": [n for n in notes if n not in informational],
           "figure": None, "aep_figure": None}
    if curves is not None and len(curves):
        out["figure"] = power_curve_figure(curves)
    if rows and all(r.get("aep_elec_mwh") is not None for r in rows):
        out["aep_figure"] = aep_figure(pd.DataFrame(rows))
    return out


def aep_row(r: dict) -> dict:
    """One row of the AEP table (strings) from an ``aep.json`` kind."""
    band = (f"{fmt(r.get('ci95_aep_elec_low_mwh'), 3)} to "
            f"{fmt(r.get('ci95_aep_elec_high_mwh'), 3)}"
            if r.get("ci95_aep_elec_low_mwh") is not None else "n/a")
    return {"kind": f"{r.get('kind')} ({LABELS.get(r.get('kind'), '')})",
            "aep_elec": fmt(r.get("aep_elec_mwh"), 3), "band": band,
            "aep_mech": fmt(r.get("aep_mech_mwh"), 3),
            "cf_elec": _pct(r.get("capacity_factor_elec")),
            "cf_mech": _pct(r.get("capacity_factor_mech")),
            "eff_loss": fmt(r.get("efficiency_loss_mwh"), 3),
            "limit_loss": (fmt(r.get("limit_loss_mwh"), 3) if r.get("limit_loss_mwh") is not None
                           else "n/a (no limits)"),
            "cut_in": cut_in_text(r) if "delivers_at_grid_start" in r else fmt(
                r.get("cut_in_elec_m_s"), 2),
            "below": (_pct(r.get("energy_below_grid")) if r.get("delivers_at_grid_start")
                      else "none" if "delivers_at_grid_start" in r else "n/a"),
            "above": _pct(r.get("energy_above_grid")),
            "coverage": coverage_note(r)}


def loss_rows(losses: dict) -> list[tuple[str, str]]:
    """The losses split of ``aep.json`` as (what, MWh/yr) pairs."""
    return [
        ("lost to the drive limits, electrical objective [MWh/yr]",
         fmt(losses.get("limits_elec_objective_mwh"), 3)),
        ("lost to the drive limits, mechanical objective, shaft energy [MWh/yr]",
         fmt(losses.get("limits_mech_objective_mech_mwh"), 3)),
    ] + [(f"lost to the drive's efficiency, {k} [MWh/yr]", fmt(v, 3))
         for k, v in (losses.get("efficiency_by_kind_mwh") or {}).items()]


def continuous_rating_text(candidate: dict) -> str:
    """Where a candidate's continuous rating binds: the winding temperature (with its
    peak) when the cycle carried it, else the RMS torque; ``"none"``."""
    peak = candidate.get("peak_winding_temperature_c")
    if peak is not None:
        at = candidate.get("thermal_bound_active_at") or "none"
        return f"winding: {at} (peak {fmt(peak, 1)} degC)"
    return candidate.get("rms_bound_active_at") or "none"


def x1_band(aep_doc: dict | None, sizing: dict) -> float | None:
    """The relative half-width of the AEP table's elec-lim 95 % band, when x1 is that
    drive (the same losses, at the same site), else None."""
    row = next((r for r in (aep_doc or {}).get("kinds") or [] if r.get("kind") == "elec-lim"),
               None)
    losses = (((aep_doc or {}).get("optimize") or {}).get("drive_model") or {}).get(
        "model_sha256")
    if (row is None or row.get("ci95_aep_elec_high_mwh") is None or not row.get("aep_elec_mwh")
            or not _same_site(aep_doc.get("site"), sizing.get("site"))
            or losses != (sizing.get("reference_drive") or {}).get("model_sha256")):
        return None
    return (row["ci95_aep_elec_high_mwh"] - row["ci95_aep_elec_low_mwh"]) / 2 / row[
        "aep_elec_mwh"]


def decision_rows(sizing: dict, aep_doc: dict | None) -> list[tuple[str, str]]:
    """The sizing's Key results: the chosen drive with its rating, its AEP with a band and
    the margin to the next candidate, and the grid it was chosen on; or, where the grid
    leaves out too much of the site, that it is not a decision and why
    (:func:`energy.decision.decision`)."""
    d = sizing.get("decision")
    if not isinstance(d, dict):
        return [("drive sizing", "no decision recorded (sizing.json from an older version): "
                                 "run bench size again")]
    grid = (sizing.get("coverage") or {}).get("note", "")
    if not d.get("holds") or d.get("chosen") is None:
        return [("drive sizing", f"{d.get('line')}")]
    cands = {c.get("candidate"): c for c in sizing.get("candidates") or []}
    c, best = cands[d["chosen"]], cands[d["best"]]
    band = x1_band(aep_doc, sizing)
    band_text = (f"95 %: +-{100 * band:.1f} %, x1's relative band in the AEP table carried "
                 "to it" if band is not None else
                 "no band: bench size solves none; bench aep gives x1's")
    margin = ("it is the best" if c is best else
              f"{100 * (1 - float(c['aep_share_of_best'])):.1f} % below the best, "
              f"{d['best']} ({fmt(best.get('aep_elec_mwh'), 3)} MWh/yr)")
    nxt = d.get("next_smaller")
    if nxt:
        share = float(nxt["aep_elec_mwh"]) / float(best["aep_elec_mwh"])
        margin += (f"; the next smaller, {nxt['candidate']}, delivers "
                   f"{fmt(nxt['aep_elec_mwh'], 3)} MWh/yr, {100 * share:.1f} % of the best "
                   f"(the rule needs {100 * (1 - float(sizing.get('tolerance') or 0)):.0f} %)")
    return [("drive chosen",
             f"{d['chosen']}: {limits_text(c)}, nominal power {fmt(c.get('nominal_power_w'), 0)}"
             f" W; electrical AEP {fmt(c.get('aep_elec_mwh'), 3)} MWh/yr on the sizing grid "
             f"({band_text}); {margin}"),
            ("drive sizing grid", grid + (f"; {sizing['edge']['note']}"
                                          if (sizing.get("edge") or {}).get("note") else ""))]


def sizing_context(sizing: dict, aep_doc: dict | None = None) -> dict:
    """The sizing part of the section from ``sizing.json`` (``aep_doc``: the AEP stage's
    ``aep.json``, for x1's band)."""
    cands = sizing.get("candidates") or []
    decision = sizing.get("decision") or {}
    return {
        "headline": decision_rows(sizing, aep_doc),
        "decision": decision.get("line"), "holds": bool(decision.get("holds")),
        "rows": [{"candidate": c.get("candidate"), "limits": limits_text(c),
                  "flown": (f"{fmt(c.get('peak_torque_flown_nm'), 1)} N m, "
                            f"{fmt(c.get('peak_speed_flown_rpm'), 0)} rpm"),
                  "nominal": fmt(c.get("nominal_power_w"), 0),
                  "aep": fmt(c.get("aep_elec_mwh"), 3),
                  "share": _pct(c.get("aep_share_of_best")),
                  "cf": _pct(c.get("capacity_factor_elec")),
                  "rms_active": continuous_rating_text(c),
                  "converged": f"{c.get('n_converged')}/{c.get('n_winds')}"}
                 for c in cands],
        "best": sizing.get("best"), "chosen": sizing.get("chosen"),
        "tolerance": _pct(sizing.get("tolerance")),
        "law": sizing.get("law"), "wind_speeds": ", ".join(f"{w:g}" for w in
                                                     sizing.get("wind_speeds_m_s") or []),
        "wall": fmt(sizing.get("wall_time_s"), 1), "executor": sizing.get("executor"),
        "solved": sizing.get("n_solved"), "loaded": sizing.get("n_loaded"),
        "edge": (sizing.get("edge") or {}).get("note"),
        "edge_at": (sizing.get("edge") or {}).get("best_at"),
        "hours": (sizing.get("coverage") or {}).get("note"),
        "figure": sizing_figure(cands, sizing.get("chosen")) if cands else None,
    }


def _same_site(a: dict | None, b: dict | None) -> bool:
    keys = ("type", "k", "scale_m_s", "edges_m_s", "probabilities")
    return bool(a and b) and all(a.get(k) == b.get(k) for k in keys)


def grid_difference(aep_doc: dict, curves: pd.DataFrame | None, sizing: dict) -> str | None:
    """How far x1's sizing AEP lies from the AEP table's elec-lim AEP, and how much of that
    the two stages' wind grids make: the AEP stage's elec-lim curve taken at the sizing
    grid's speeds (linear between its own) and integrated as the sizing integrates.

    Returns None without an x1 with an AEP, an elec-lim AEP or its curve.
    """
    from energy.aep import aep_mwh
    from energy.site import site_from_dict

    x1 = next((c for c in sizing.get("candidates") or [] if c.get("scale") == 1.0), None)
    row = next((r for r in aep_doc.get("kinds") or [] if r.get("kind") == "elec-lim"), None)
    if (x1 is None or row is None or x1.get("aep_elec_mwh") is None
            or row.get("aep_elec_mwh") is None or curves is None):
        return None
    own, other = float(x1["aep_elec_mwh"]), float(row["aep_elec_mwh"])
    head = (f"x1 against the AEP table's elec-lim: {own:.3f} against {other:.3f} MWh/yr "
            f"({100 * (own / other - 1):+.2f} %)")
    losses = ((aep_doc.get("optimize") or {}).get("drive_model") or {}).get("model_sha256")
    if not _same_site(aep_doc.get("site"), sizing.get("site")):
        return f"{head}: at another site, not compared."
    if losses != (sizing.get("reference_drive") or {}).get("model_sha256"):
        return f"{head}: x1 has other losses than the optimization's drive, not compared."
    curve = curves[curves["kind"] == "elec-lim"].sort_values("wind_speed_m_s")
    theirs = curve["wind_speed_m_s"].to_numpy(float)
    ours = np.array(sorted({float(r["wind_speed_m_s"]) for r in sizing.get("solves") or []
                            if r.get("candidate") == x1.get("candidate")}))
    if len(ours) == len(theirs) and np.allclose(ours, theirs):
        return f"{head}, on the same wind grid."
    grids = (f"the wind grids differ (sizing: {len(ours)} speeds {ours[0]:g}-{ours[-1]:g} "
             f"m/s; AEP stage: {len(theirs)} speeds {theirs[0]:g}-{theirs[-1]:g} m/s)")
    if ours[0] < theirs[0] or ours[-1] > theirs[-1]:
        return f"{head}; {grids}: the sizing grid reaches beyond the AEP stage's, not split."
    on_ours = aep_mwh(ours, np.interp(ours, theirs, curve["p_elec_w"].to_numpy(float)),
                      site_from_dict(aep_doc["site"]))
    return (f"{head}; {grids}. The AEP stage's elec-lim curve at the sizing speeds gives "
            f"{on_ours:.3f} MWh/yr: the grids make {on_ours - other:+.3f} MWh/yr "
            f"({100 * (on_ours / other - 1):+.2f} %) of the difference, the solves at the "
            f"sizing speeds (and the AEP curve's interpolation there) "
            f"{own - on_ours:+.3f} MWh/yr ({100 * (own / on_ours - 1):+.2f} %).")


def coverage_note(row: dict) -> str:
    """Which part of the site an ``aep.json`` kind's AEP covers, in one sentence: the share
    of the site's available wind energy (and of its hours) its grid covers, what lies below
    it (left out where the kind delivers at the grid's first speed: its cut-in lies below
    the grid) and above it."""
    from energy.site import ENERGY_LEFT_OUT

    lo, hi = row.get("grid_min_m_s"), row.get("grid_max_m_s")
    if row.get("energy_left_out") is None or lo is None or hi is None:
        return ("share of the site's wind energy covered: not recorded (aep.json from an "
                "older version)")
    left, hours = row["energy_left_out"], row.get("share_left_out") or 0.0
    below = (f"{_pct(row.get('energy_below_grid'))} of the wind energy below {lo:g} m/s, where "
             "it already delivers (its cut-in lies below the grid, not found), counts as zero"
             if row.get("delivers_at_grid_start") else
             f"below {lo:g} m/s it delivers nothing (cut-in {fmt(row.get('cut_in_elec_m_s'), 2)}"
             " m/s)")
    above = f"{_pct(row.get('energy_above_grid'))} above {hi:g} m/s counts as zero"
    verdict = "" if left <= ENERGY_LEFT_OUT else "only part of the site's AEP: "
    return (f"{verdict}wind grid {lo:g}-{hi:g} m/s covers {_pct(1.0 - left)} of the site's "
            f"wind energy ({_pct(1.0 - hours)} of its hours); {below}; {above}")


def _pct(x) -> str:
    return "n/a" if x is None or not np.isfinite(float(x)) else f"{100 * float(x):.1f} %"
