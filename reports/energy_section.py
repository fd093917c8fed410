"""The report's energy section: power curves with bands, AEP per scenario kind, losses, sizing.

Reads ``aep_out/aep.json``, ``aep_out/power_curves.csv`` and ``size_out/sizing.json``
(docs/schemas.md §7) through the :class:`reports.inputs.InputLog`; every missing file
is listed in ``missing`` and the template says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from energy.bands import Z95
from energy.outputs import POWER_CURVE_COLUMNS as CURVE_COLUMNS
from optimize.kinds import LABELS
from reports import svg
from reports.inputs import InputLog
from reports.tables import fmt


def _color(kind: str) -> str:
    return svg.SCENARIO_COLORS.get(kind, "#444444")


def power_curve_figure(curves) -> object:
    """Delivered electrical power per kind with its 95 % band; mechanical power dashed."""
    fig = svg.new_figure(7.0, 4.2)
    ax = fig.add_subplot()
    for kind, rows in curves.groupby("kind", sort=False):
        rows = rows.sort_values("wind_speed_m_s")
        v = rows["wind_speed_m_s"].to_numpy(float)
        d = -rows["p_elec_w"].to_numpy(float)
        s = rows["p_elec_sigma_w"].to_numpy(float)
        c = _color(str(kind))
        ax.plot(v, d, "o-", color=c, label=f"{svg.plain_label(kind)} electrical")
        if np.all(np.isfinite(s)):
            ax.fill_between(v, d - Z95 * s, d + Z95 * s, color=c, alpha=0.25, lw=0)
        ax.plot(v, -rows["p_mech_w"].to_numpy(float), "--", color=c, lw=1, alpha=0.8)
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("wind speed at the reference height [m/s]")
    ax.set_ylabel("average power delivered [W]")
    ax.set_title("Power curves (solid electrical with 95 % band, dashed mechanical)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return svg.to_svg(fig, "energy-power-curves")


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
    """Section 5: AEP, bands, losses, sizing.

    Returns
    -------
    dict
        ``site``, ``nominal``, ``table`` (rows of strings), ``losses``, ``notes``,
        ``figure``, ``sizing`` (or None), ``missing``, ``not_run``, ``records`` (the
        decoded ``aep.json`` and ``sizing.json``, or None).
    """
    start = len(log.missing)
    # optional stages: a folder that does not exist means the stage was not run (said in
    # ``not_run``); a folder without its files is a missing input
    not_run = [f"bench {name} (no {folder})" for name, folder in (("aep", aep), ("size", size))
               if not Path(folder).is_dir()]
    doc = log.json(Path(aep) / "aep.json") if Path(aep).is_dir() else None
    curves = log.csv(Path(aep) / "power_curves.csv", CURVE_COLUMNS) if doc is not None else None
    out: dict = {"site": None, "nominal": None, "table": [], "losses": [], "notes": [],
                 "figure": None, "sizing": None, "sign": None, "interpolation": None}
    if doc is not None:
        site = doc.get("site") or {}
        out["site"] = site.get("note")
        out["nominal"] = (f"{fmt(doc.get('nominal_power_w'), 0)} W "
                          f"({doc.get('nominal_power_source')})")
        out["sign"], out["interpolation"] = doc.get("sign_convention"), doc.get("interpolation")
        for r in doc.get("kinds") or []:
            band = (f"{fmt(r.get('ci95_aep_elec_low_mwh'), 3)} to "
                    f"{fmt(r.get('ci95_aep_elec_high_mwh'), 3)}"
                    if r.get("ci95_aep_elec_low_mwh") is not None else "n/a")
            out["table"].append({
                "kind": f"{r.get('kind')} ({LABELS.get(r.get('kind'), '')})",
                "aep_elec": fmt(r.get("aep_elec_mwh"), 3), "band": band,
                "aep_mech": fmt(r.get("aep_mech_mwh"), 3),
                "cf_elec": _pct(r.get("capacity_factor_elec")),
                "cf_mech": _pct(r.get("capacity_factor_mech")),
                "eff_loss": fmt(r.get("efficiency_loss_mwh"), 3),
                "limit_loss": fmt(r.get("limit_loss_mwh"), 3),
                "cut_in": fmt(r.get("cut_in_elec_m_s"), 2),
                "above": _pct(r.get("share_above_grid")),
                "left_out": _pct(r.get("share_left_out")),
                "coverage": coverage_note(r),
            })
        losses = doc.get("losses") or {}
        out["losses"] = [
            ("lost to the drive limits, electrical objective [MWh/yr]",
             fmt(losses.get("limits_elec_objective_mwh"), 3)),
            ("lost to the drive limits, mechanical objective, shaft energy [MWh/yr]",
             fmt(losses.get("limits_mech_objective_mech_mwh"), 3)),
        ] + [(f"lost to the drive's efficiency, {k} [MWh/yr]", fmt(v, 3))
             for k, v in (losses.get("efficiency_by_kind_mwh") or {}).items()]
        out["notes"] = [str(n) for n in doc.get("notes") or []]
        if curves is not None and len(curves):
            for col in CURVE_COLUMNS[2:]:
                curves[col] = curves[col].astype(float)
            out["figure"] = power_curve_figure(curves)
    sizing = log.json(Path(size) / "sizing.json") if Path(size).is_dir() else None
    if sizing is not None:
        cands = sizing.get("candidates") or []
        out["sizing"] = {
            "rows": [{"candidate": c.get("candidate"),
                      "rated": fmt(c.get("rated_torque_nm"), 1),
                      "peak": fmt(c.get("peak_torque_nm"), 0),
                      "nominal": fmt(c.get("nominal_power_w"), 0),
                      "aep": fmt(c.get("aep_elec_mwh"), 3),
                      "share": _pct(c.get("aep_share_of_best")),
                      "cf": _pct(c.get("capacity_factor_elec")),
                      "rms_active": c.get("rms_bound_active_at") or "none",
                      "converged": f"{c.get('n_converged')}/{c.get('n_winds')}"}
                     for c in cands],
            "best": sizing.get("best"), "chosen": sizing.get("chosen"),
            "tolerance": _pct(sizing.get("tolerance")),
            "law": sizing.get("law"), "winds": ", ".join(f"{w:g}" for w in
                                                         sizing.get("wind_speeds_m_s") or []),
            "wall": fmt(sizing.get("wall_time_s"), 1), "executor": sizing.get("executor"),
            "solved": sizing.get("n_solved"), "loaded": sizing.get("n_loaded"),
            "edge": (sizing.get("edge") or {}).get("note"),
            "edge_at": (sizing.get("edge") or {}).get("best_at"),
            "hours": (sizing.get("hours") or {}).get("note"),
            "figure": sizing_figure(cands, sizing.get("chosen")) if cands else None,
        }
    out["missing"] = list(dict.fromkeys(log.missing[start:]))
    out["not_run"] = not_run
    out["records"] = {"aep": doc, "size": sizing}  # their provenance headers
    return out


def coverage_note(row: dict) -> str:
    """Which of the site's hours an ``aep.json`` kind's AEP covers, in one sentence."""
    left, lo, hi = (row.get(k) for k in ("share_left_out", "grid_min_m_s", "grid_max_m_s"))
    if left is None or lo is None or hi is None:
        return "share of the site's hours covered: not recorded (aep.json from an older version)"
    below, above = row.get("share_below_grid") or 0.0, row.get("share_above_grid") or 0.0
    parts = [f"{_pct(above)} above {hi:g} m/s count as zero"]
    if below > 0:
        parts.insert(0, f"{_pct(below)} below {lo:g} m/s "
                     + ("count as zero" if left > above else "deliver nothing, under the "
                        f"cut-in of {fmt(row.get('cut_in_elec_m_s'), 2)} m/s"))
    verdict = "" if left < 0.01 else "only part of the site's AEP: "
    return (f"{verdict}wind grid {lo:g}-{hi:g} m/s covers {_pct(1.0 - left)} of the site's "
            f"hours ({'; '.join(parts)})")


def _pct(x) -> str:
    return "n/a" if x is None or not np.isfinite(float(x)) else f"{100 * float(x):.1f} %"
