"""The report's optimization section: the optimized cycles (Table II, Figs. 8, 9, 10, 3, claims).

Reads ``optimize_out/summary.parquet`` (one row per scenario, with solver status),
``trajectories.parquet`` (every collocation point, a ``scenario`` column),
``manifest.json`` and ``claims.csv`` (docs/schemas.md §5). A scenario that did not
converge is shown as failed with its status and is never plotted or compared.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from kernel.drive import Drive
from kernel.errors import InputError
from kernel.units import power_words
from optimize.door import KINDS, LABELS, Cycle, envelope_curve
from optimize.sweep_folder import (
    CLAIMS_FILE,
    FINER_MESH_HEAD,
    MANIFEST_FILE,
    SUMMARY_FILE,
    TRAJECTORIES_FILE,
    UNCHECKED_HEAD,
    domain_excursions,
    domain_line,
    on_bounds,
    read_claims,
    read_manifest,
    read_summary,
    read_trajectories,
    remesh_lines,
    unchecked_lines,
)
from reports import cycle_figures
from reports.failed import failed_rows, failure_text
from reports.inputs import InputLog
from reports.section_list import section_name
from reports.tables import fmt, frame_table, value_text
from reports.trust_checks import trust_checks

#: Fig. 3: electrically optimized, constrained cycle at 5.5 m/s.
FIG3_KIND, FIG3_WIND_M_S = "elec-lim", 5.5
#: The wind speed of the paper's Figs. 9 and 10 and of its cycle periods [m/s]
#: (docs/paper_figures.md §4, statement 6).
PAPER_FIG9_WIND_M_S = 10.0


def is_paper_system(manifest: dict | None) -> bool:
    """Whether the sweep flew the paper's system (``[system] paper_system = true`` in the
    system text its manifest records; a sweep before system files flew the paper's kite):
    only then does the report compare with the paper's figures and statements."""
    from kernel.files import parse_toml

    rec = (manifest or {}).get("system")
    if not isinstance(rec, dict) or not isinstance(rec.get("text"), str):
        return not isinstance(rec, dict)
    try:
        data = parse_toml(rec["text"], Path(str(rec.get("path"))), what="the sweep's system")
    except InputError:
        return False
    return bool((data.get("system") or {}).get("paper_system", False))


def key_warnings(summary: pd.DataFrame) -> list[tuple[str, str]]:
    """What Key results must say about the cycles themselves: those that run most of their
    time outside the drive model's validity domain (there the model extrapolates), and
    those that draw net power from the grid while the drum generates (their drive's
    losses exceed what the drum delivers): the largest with the losses that explain its
    draw, and those whose losses inside the domain alone would not make them draw (section
    4 itemizes each, :func:`draw_rows`)."""
    ok = summary[summary["success"].astype(bool)]
    rows = []
    if "outside_domain_time_frac" in ok.columns:
        frac = ok["outside_domain_time_frac"].astype(float)
        most = ok[frac > 0.5]
        if len(most):
            worst = most.loc[frac[frac > 0.5].idxmax()]
            rows.append(("outside the drive model's domain", (
                f"{len(most)} of {len(ok)} converged cycles spend most of their time outside the "
                f"drive model's validity domain (its measured envelope, where it extrapolates): "
                f"{_scenario_list(most)}; worst {worst['scenario']}, "
                f"{100 * float(worst['outside_domain_time_frac']):.0f} % of its cycle")))
    losing = _drawing(ok)
    if len(losing):
        resting = losing[[_rests_on_extrapolation(r) for _, r in losing.iterrows()]]
        rest = (f"; the draws of {_scenario_list(resting)} rest on losses the model "
                "extrapolates (those inside its domain alone would not make them draw)"
                if len(resting) and len(losing) > 1 else "")
        rows.append(("drawing from the grid while generating", (
            f"{len(losing)} converged cycles draw net power from the grid while the drum "
            f"generates (the drive's losses exceed the drum's power): {_scenario_list(losing)}; "
            f"largest {_draw_words(losing.iloc[0])}{rest}"
            + (f"; {section_name('optimization')} gives each cycle's losses"
               if len(losing) > 1 else ""))))
    return rows


def draw_rows(summary: pd.DataFrame) -> list[str]:
    """Per converged cycle that draws net power while the drum generates, the largest
    losses first: what it draws, what the drum generates, the drive's losses that explain
    the difference and how much of them the model extrapolates (:func:`_draw_words`)."""
    ok = summary[summary["success"].astype(bool)]
    return [_draw_words(r) for _, r in _drawing(ok).iterrows()]


def _drawing(ok: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``ok`` that draw from the grid while the drum generates, the largest
    drive losses (P_elec - P_mech) first."""
    p_elec, p_mech = ok["avg_p_elec_w"].astype(float), ok["avg_p_mech_w"].astype(float)
    losing = ok[(p_elec > 0) & (p_mech < 0)]
    return losing.loc[(p_elec - p_mech)[losing.index].sort_values(ascending=False).index]


def _inside_loss_w(row: pd.Series) -> float:
    """The drive losses [W] of a summary row at points inside the model's domain; NaN
    where the summary states no loss share."""
    share = float(row.get("outside_domain_loss_frac", float("nan")))
    return (1.0 - share) * (float(row["avg_p_elec_w"]) - float(row["avg_p_mech_w"]))


def _rests_on_extrapolation(row: pd.Series) -> bool:
    """Whether a cycle drawing while the drum generates would not draw on the losses
    inside the model's domain alone."""
    return bool(_inside_loss_w(row) < -float(row["avg_p_mech_w"]))


def _draw_words(row: pd.Series) -> str:
    """One cycle that draws while the drum generates: what it draws, what the drum
    generates, the drive's losses that explain the difference and, where the summary
    states it, their share outside the model's domain."""
    p_elec, p_mech = float(row["avg_p_elec_w"]), float(row["avg_p_mech_w"])
    return (f"{row['scenario']}: {power_words(p_elec)} drawn, {power_words(-p_mech)} generated "
            f"at the drum, the drive's losses {power_words(p_elec - p_mech)} over the "
            f"cycle{_extrapolated(row)}")


def _extrapolated(row: pd.Series) -> str:
    """``, 89 % of them outside ...`` for a summary row that states the share of its drive
    losses outside the model's domain, with whether the losses inside it alone would make
    the cycle draw; else ``""``."""
    share = float(row.get("outside_domain_loss_frac", float("nan")))
    if not share > 0:
        return ""
    verdict = ("would not make it draw: the draw rests on the extrapolation"
               if _rests_on_extrapolation(row) else "would make it draw too")
    return (f", {100 * share:.0f} % of them at points outside the drive model's domain, "
            f"where it extrapolates (the {power_words(_inside_loss_w(row))} inside it alone "
            f"{verdict})")


def drive_checks(manifest: dict | None) -> list[tuple[str, str]]:
    """What the drive in force assumes that a real machine would not (the manifest's
    ``drive.checks``, :mod:`optimize.system.drive_power_check`), for Key results."""
    checks = ((manifest or {}).get("drive") or {}).get("checks") or []
    return [("drive in force", str(c)) for c in checks]


def _scenario_list(rows: pd.DataFrame) -> str:
    """Scenarios by kind: ``mech-lim at 6, 9 m/s; mech-free at 12 m/s``."""
    return "; ".join(f"{kind} at {', '.join(fmt(w, sig=3) for w in sorted(g['wind_speed_m_s']))}"
                     " m/s" for kind, g in rows.groupby("kind", sort=False))


def normalized_summary(summary: pd.DataFrame, path: Path) -> pd.DataFrame:
    """Summary with an ``ok`` column added (converged with a finite power).

    Raises
    ------
    InputError
        On a scenario kind not in :data:`optimize.kinds.KINDS`.
    """
    out = summary.copy()
    unknown = sorted(set(out["kind"].astype(str)) - set(KINDS))
    if unknown:
        raise InputError(path, f"unknown scenario kind {unknown[0]!r}", column="kind",
                         expected=", ".join(KINDS))
    out["ok"] = out["success"].astype(bool) & np.isfinite(out["avg_p_elec_w"].astype(float))
    return out


def domain_rows(summary: pd.DataFrame) -> list[str] | None:
    """Per converged scenario leaving the drive model's validity domain: one line
    (:func:`optimize.sweep_folder.domain_line`, as ``bench optimize`` prints it).

    None when the summary has no ``outside_domain_time_frac`` column (an older sweep)
    or the model had no domain (all NaN); an empty list when every cycle stays inside.
    """
    rows = domain_excursions(summary)
    return None if rows is None else [domain_line(r) for r in rows.itertuples(index=False)]


def table_ii(summary: pd.DataFrame) -> dict:
    """Table II analogue: one row per wind speed, P_elec / P_mech [W] per scenario kind.

    Failed scenarios show ``failed (<status>)`` instead of numbers.
    """
    kinds = [k for k in KINDS if k in set(summary["kind"])]
    rows = []
    for wind, group in summary.groupby("wind_speed_m_s", sort=True):
        cells = []
        for kind in kinds:
            hit = group[group["kind"] == kind]
            if hit.empty:
                cells.append({"elec": "", "mech": "", "failed": None})
                continue
            r = hit.iloc[0]
            if r["ok"]:
                cells.append({"elec": fmt(r["avg_p_elec_w"], 0), "mech": fmt(r["avg_p_mech_w"], 0),
                              "failed": None})
            else:
                cells.append({"elec": "", "mech": "", "failed": failure_text(r)})
        rows.append({"wind": fmt(wind, sig=3), "cells": cells})
    labels = [LABELS[k] for k in kinds]
    return {"kinds": kinds, "labels": labels, "rows": rows}


def _cycle(traj: pd.DataFrame | None, summary: pd.DataFrame, kind: str,
           wind: float) -> tuple[Cycle | None, str | None]:
    """The cycle of a converged scenario (:class:`optimize.cycles.Cycle`), or (None, why
    not)."""
    hit = summary[(summary["kind"] == kind) & np.isclose(summary["wind_speed_m_s"], wind)]
    if hit.empty:
        return None, f"scenario {kind} at {wind:g} m/s was not run"
    row = hit.iloc[0]
    if not row["ok"]:
        return None, f"scenario {row['scenario']} failed ({row['status']})"
    if traj is None:
        return None, "trajectories.parquet missing"
    rows = traj[traj["scenario"] == row["scenario"]]
    if rows.empty:
        return None, f"no trajectory rows for scenario {row['scenario']}"
    return Cycle.of(rows), None


def run_rows(manifest: dict, fit_model_sha256: str | None) -> list[tuple[str, str]]:
    """How the sweep ran (executor, wall time, convergence, drive model, options) as pairs.

    The drive model the sweep used is compared with the fitted model of the
    report's power-model section (canonical SHA-256, docs/schemas.md §3).
    """
    rows = []
    for key in ("executor", "wall_time_s", "converged", "failed"):
        if key in manifest:
            value = manifest[key]
            rows.append((key, fmt(value, 1) if isinstance(value, float) else value_text(value)))
    its = manifest.get("iterations")
    options = manifest.get("options")
    solver = options.get("solver") if isinstance(options, dict) else None
    name = "fatrop" if isinstance(solver, dict) and solver.get("solver") == "fatrop" else "IPOPT"
    if isinstance(its, dict):  # docs/schemas.md §5, manifest "iterations"
        rows.append((f"{name} iterations",
                     f"{its.get('reported', 0)} in the scenarios' final solves; "
                     f"{its.get('intermediate_points', 0)} intermediate points on the way to "
                     f"them ({its.get('intermediate_iterations', 0)} iterations, not results); "
                     f"{its.get('all', 0)} in all"
                     + "".join(f"; {role} {n}" for role, n in its.get("by_role", {}).items())))
    drive = manifest.get("drive_model")
    if isinstance(drive, dict):
        rows.append(("drive model", f"{drive.get('name', '?')} ({drive.get('path', '?')})"))
        used = drive.get("model_sha256")
        if used and fit_model_sha256:
            same = "yes" if used == fit_model_sha256 else "NO: the sweep used another model"
            rows.append((f"same model as {section_name('model')}", same))
    options = manifest.get("options")
    if isinstance(options, dict):  # {group: {option: value}}
        for group, values in options.items():
            items = values.items() if isinstance(values, dict) else [(group, values)]
            rows.extend((f"option {k}", value_text(v)) for k, v in items)
    return rows


def cut_in_rows(manifest: dict) -> list[dict]:
    """Cut-in wind speeds (net electrical power crosses zero) the sweep's search looked for:
    ``cut_in`` empty where it found none (``status`` says why; the table shows "not
    found")."""
    rows = []
    for c in manifest.get("cut_in") or []:
        if isinstance(c, dict):
            lo, hi = c.get("bracket_lo_m_s"), c.get("bracket_hi_m_s")
            rows.append({"kind": str(c.get("kind", "")),
                         "label": LABELS.get(str(c.get("kind")), ""),
                         "cut_in": fmt(c.get("cut_in_m_s"), 2),
                         "bracket": (f"{fmt(lo, 3)} - {fmt(hi, 3)}" if lo is not None
                                     else "none"),
                         "status": str(c.get("status") or "not recorded")})
    return rows


def claims_rows(claims: pd.DataFrame) -> list[dict]:
    """Rows of claims.csv (statement, paper, ours, verdict, note) as plain strings."""
    columns = ("claim_id", "statement", "paper", "ours", "verdict", "note")
    return [{c: str(r.get(c, "")) for c in columns} for r in claims.to_dict(orient="records")]


#: what each name of ``active_bounds`` (docs/schemas.md §5) means, and the unit of its
#: value (the manifest's ``bound_values`` holds the value by the same name)
BOUND_MEANINGS = {
    "period_min": ("the cycle period at the shortest of its search range", "s"),
    "period_max": ("the cycle period at the longest of its search range", "s"),
    "tether_length_min": ("the tether at the shortest of its search range", "m"),
    "tether_length_max": ("the tether at the longest of its search range", "m"),
    "ground_clearance": ("the kite at its lowest allowed altitude", "m"),
    "airspeed_min": ("the kite at its least airspeed (the kite's limit, every kind)", "m/s"),
    "airspeed_max": ("the kite at its largest airspeed (the kite's limit, every kind)",
                     "m/s"),
    "alpha_min": ("the kite at the lowest angle of attack of its range, below which its "
                  "aero coefficients are not valid (every kind)", "deg"),
    "alpha_max": ("the kite at the highest angle of attack of its range, above which its "
                  "aero coefficients are not valid (every kind)", "deg"),
    "beta_min": ("the kite at the lowest sideslip of its range (every kind)", "deg"),
    "beta_max": ("the kite at the highest sideslip of its range (every kind)", "deg"),
    "line_angle_limit": ("the tether at its largest angle to the kite's body z axis (every kind)",
                         "deg"),
    "tether_force_limit": ("the tether at its largest force (the kite's limit, every kind)",
                           "N"),
    "tension_min": ("the tether at its least tension: a line that must stay taut (every "
                    "kind)", "N"),
    "reel_acceleration_limit": ("the winch at its largest reel acceleration (every kind)",
                                "m/s^2"),
    "reel_jerk_limit": ("the winch at its largest reel jerk (every kind)", "m/s^3"),
    "reel_out_speed_limit": ("the winch at its largest reel-out speed (every kind)", "m/s"),
    "reel_in_speed_limit": ("the winch at its largest reel-in speed (every kind)", "m/s"),
    "body_rate_limit": ("a body rate of the kite (roll, pitch or yaw) at its bound (every "
                        "kind)", "deg/s"),
    "surface_limit": ("a control surface (aileron, elevator, rudder) at its largest "
                      "deflection: the kite's own actuator limit, in force in every kind, "
                      "the unconstrained ones included (the kind's 'free' frees the drive, "
                      "not the kite)", "deg"),
    "speed_limit": ("the drive at its speed limit (constrained kinds)", "rpm"),
    "torque_limit": ("the drive at its torque limit (constrained kinds)", "N m"),
    "envelope_limit": ("the drive on its torque-speed envelope above base speed (constrained "
                       "kinds)", "rpm base speed"),
    "p_elec_limit": ("the grid connection at its largest power (constrained kinds)", "W"),
    "winding_temperature_limit": ("the drive's winding at its largest temperature "
                                  "(constrained kinds)", "degC"),
}


def bound_legend(rows: list[dict], values: dict) -> list[str]:
    """What each bound name in the table ``rows`` (:func:`bound_rows`) means, once each, with
    its value as flown (``bound_values`` of the manifest, by the same names)."""
    names = dict.fromkeys(n.strip() for r in rows for n in r["active_bounds"].split(",")
                          if n.strip() and n.strip() != "none")
    out = []
    for name in names:
        meaning, unit = BOUND_MEANINGS.get(name, ("see docs/schemas.md section 5", None))
        value = values.get(name) if unit else None
        shown = (f" ({value_text(value)} {unit})" if value is not None else "")
        out.append(f"{name}: {meaning}{shown}")
    return out


def bound_rows(summary: pd.DataFrame) -> list[dict]:
    """Converged scenarios on a bound or with a slack tether
    (:func:`optimize.sweep_folder.on_bounds`), one table row each; none for a summary
    written before ``active_bounds``, ``bound_limited`` and ``slack_fraction`` existed."""
    rows = []
    for r in on_bounds(summary).itertuples(index=False):
        slack = float(r.slack_fraction)
        rows.append({"scenario": r.scenario, "active_bounds": r.active_bounds or "none",
                     "bound_limited": bool(r.bound_limited),
                     "slack": f"{100 * slack:.1f} %" if np.isfinite(slack) else "n/a"})
    return rows


def kite_limits_line(manifest: dict) -> str | None:
    """The kite's tether-force and airspeed limits of the sweep, from its manifest."""
    k = manifest.get("kite_limits")
    if not isinstance(k, dict):
        return None
    force = k.get("max_tether_force_n")
    top = k.get("max_airspeed_m_s")
    return ("Kite limits in every scenario kind: "
            + (f"tether force at most {fmt(force, 0)} N" if force is not None
               else "no tether-force limit (the system file gives none)")
            + f"; airspeed from {fmt(k.get('min_airspeed_m_s'), 1)} m/s to "
            + (f"{fmt(top, 1)} m/s." if top is not None else "no upper limit."))


def optimization_section(log: InputLog, optimize: Path, drawn_map: dict | None,
                         fit_model_sha256: str | None = None) -> dict:
    """The optimization section's context.

    Parameters
    ----------
    log : InputLog
    optimize : Path
        The ``bench optimize`` output folder.
    drawn_map : dict or None
        ``map_frame`` and ``domain`` of the efficiency map, beneath Fig. 9.
    fit_model_sha256 : str, optional
        Canonical hash of the fitted model, to check the sweep used it.

    Returns
    -------
    dict
        ``table_ii``, ``n_failed``, ``scenarios`` (full summary table), ``fig8a``,
        ``fig8b`` (markup or None), ``cycles`` (:func:`cycle_figures_at_paper_wind`),
        ``fig3``, ``notes`` (why Fig. 3 is absent), ``domain`` (:func:`domain_rows`),
        ``draws`` (:func:`draw_rows`),
        ``claims``, ``run``, ``cut_in``, ``trust`` (:func:`reports.trust_checks.trust_checks`),
        ``manifest``, ``missing``, ``bounds`` (:func:`bound_rows`), ``system`` (name, hash
        and file text from the manifest, or None), ``kite_limits``
        (:func:`kite_limits_line`), ``local_optima`` (the sweep's re-solves, one line each),
        ``finer_mesh`` (scenarios solved on a finer mesh than the sweep's,
        :func:`optimize.sweep_folder.remesh_lines`) and ``finer_mesh_head`` (what they are),
        ``unchecked`` (kinds too few speeds for the local-optimum check,
        :func:`optimize.sweep_folder.unchecked_lines`) and ``unchecked_head``.
    """
    start = len(log.missing)
    optimize = Path(optimize)
    summary = log.read(optimize, SUMMARY_FILE, lambda f: read_summary(f / SUMMARY_FILE))
    traj = log.read(optimize, TRAJECTORIES_FILE, read_trajectories)
    manifest = log.read(optimize, MANIFEST_FILE, read_manifest)
    claims = log.read(optimize, CLAIMS_FILE, read_claims)
    out = manifest_context(manifest or {}, fit_model_sha256)
    paper = is_paper_system(manifest) if manifest is not None else False
    out.update({"manifest": manifest, "table_ii": None, "n_failed": 0, "n_scenarios": 0,
                "paper": paper, "key_warnings": [], "fig3_wind": fmt(FIG3_WIND_M_S, sig=3),
                "bound_legend": [],
                "scenarios": None, "fig8a": None, "fig8b": None, "cycles": None,
                "fig3": None, "notes": {"fig3": None}, "bounds": [], "failed": [],
                "finer_mesh": [], "finer_mesh_head": FINER_MESH_HEAD,
                "unchecked": [], "unchecked_head": UNCHECKED_HEAD,
                "domain": None, "draws": [],
                "claims": claims_rows(claims) if claims is not None else None})
    if summary is not None and len(summary):
        s = normalized_summary(summary, optimize / "summary.parquet")
        out.update({"table_ii": table_ii(s), "n_failed": int((~s["ok"]).sum()),
                    "failed": failed_rows(summary),
                    "n_scenarios": len(s), "scenarios": frame_table(summary),
                    "bounds": bound_rows(summary), "domain": domain_rows(summary),
                    "draws": draw_rows(summary),
                    "bound_legend": bound_legend(bound_rows(summary), flown_bounds(manifest)),
                    "finer_mesh": remesh_lines(summary),
                    "unchecked": unchecked_lines(summary),
                    "key_warnings": drive_checks(manifest) + key_warnings(summary)})
        out["fig8a"] = cycle_figures.power_vs_wind_figure(
            s, "avg_p_elec_w", "fig8a", "Average generated ELECTRICAL power (Fig. 8a)")
        out["fig8b"] = cycle_figures.power_vs_wind_figure(
            s, "avg_p_mech_w", "fig8b", "Average generated MECHANICAL power (Fig. 8b)")
        out["cycles"] = cycle_figures_at_paper_wind(traj, s, drawn_map,
                                                    flown_envelope(manifest), paper)
        wind = FIG3_WIND_M_S if paper else nearest_speed(s, FIG3_KIND, FIG3_WIND_M_S)
        out["fig3_wind"] = fmt(wind, sig=3)
        out["fig3"], out["notes"]["fig3"] = fig3(traj, s, winding_limit(manifest), wind)
    out["missing"] = list(dict.fromkeys(log.missing[start:]))
    return out


def manifest_context(manifest: dict, fit_model_sha256: str | None) -> dict:
    """What the sweep's manifest alone says: how it ran, cut-in speeds, trust checks, the
    system, the kite's limits and the local-optimum re-solves."""
    return {"run": run_rows(manifest, fit_model_sha256) if manifest else [],
            "cut_in": cut_in_rows(manifest),
            "trust": trust_checks(manifest),
            "system": manifest.get("system"),
            "kite_limits": kite_limits_line(manifest),
            "local_optima": [str(n) for n in manifest.get("local_optima") or []]}


def flown_bounds(manifest: dict | None) -> dict:
    """The bounds the sweep flew with by their ``active_bounds`` names (its manifest's
    ``bound_values``; empty when the manifest records none: one of schema version 1)."""
    values = (manifest or {}).get("bound_values")
    return values if isinstance(values, dict) else {}


def flown_envelope(manifest: dict | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The torque-speed envelope the sweep flew with (its manifest's ``[drive]`` in force,
    ``sections``), or None when its drive stated none."""
    drive = ((manifest or {}).get("sections") or {}).get("drive")
    if not isinstance(drive, dict):
        return None
    return envelope_curve(Drive.from_dict(drive, where="sections.drive"))


def nearest_speed(summary: pd.DataFrame, kind: str, wind: float) -> float:
    """The converged wind speed of ``kind`` nearest ``wind`` [m/s] (``wind`` when none)."""
    ok = summary[(summary["kind"] == kind) & summary["ok"]]["wind_speed_m_s"].astype(float)
    return wind if ok.empty else float(ok.iloc[int(np.argmin(np.abs(ok.to_numpy() - wind)))])


def cycle_figures_at_paper_wind(traj: pd.DataFrame | None, summary: pd.DataFrame,
                                drawn_map: dict | None,
                                envelope: tuple[np.ndarray, np.ndarray] | None = None,
                                paper: bool = True) -> dict:
    """Figs. 9 and 10 at the grid's wind speed nearest the paper's (:data:`PAPER_FIG9_WIND_M_S`).

    Returns
    -------
    dict
        ``wind`` (text), ``fig9``, ``fig10`` (markup or None), ``periods`` (label and
        period of each cycle without limits), ``paper_applies`` (the paper's system and
        its speed, so its periods compare), ``not_paper`` (the sentence that says why they
        do not on the paper's system, else None), ``on_map`` (the constrained cycles are
        drawn over a measured efficiency map) and ``missing`` (scenarios not drawn, and
        why). ``paper``: the sweep flew the paper's system (:func:`is_paper_system`).
    """
    wind_speeds_m_s = summary["wind_speed_m_s"].astype(float).unique()
    wind = float(wind_speeds_m_s[np.argmin(np.abs(wind_speeds_m_s - PAPER_FIG9_WIND_M_S))])
    limited, free, missing = {}, {}, []
    # the paper's order: Fig. 9 (b) mechanical, (c) electrical
    for kind in ("mech-lim", "elec-lim", "mech-free", "elec-free"):
        cycle, why = _cycle(traj, summary, kind, wind)
        if cycle is None:
            missing.append(why)
        else:
            (limited if KINDS[kind].drive_limits else free)[kind] = cycle
    applies = paper and bool(np.isclose(wind, PAPER_FIG9_WIND_M_S))
    out = {"wind": fmt(wind, sig=3), "fig9": None, "fig10": None, "missing": missing,
           "paper_applies": applies, "paper": paper,
           "on_map": bool(limited) and drawn_map is not None
           and drawn_map.get("map_frame") is not None,
           "periods": [{"label": LABELS[k], "period_s": fmt(c.period_s, 2)}
                       for k, c in free.items()],
           "not_paper": None if applies or not paper else (
               f"The paper's periods (mechanical 2.14 s, electrical 3.89 s) are for "
               f"{PAPER_FIG9_WIND_M_S:g} m/s; this sweep's grid has no "
               f"{PAPER_FIG9_WIND_M_S:g} m/s, so its cycles at {wind:g} m/s, the nearest "
               "speed, are not compared with them.")}
    limited = {k: c.closed() for k, c in limited.items()}
    free = {k: c.closed() for k, c in free.items()}
    if limited or free:
        out["fig9"] = cycle_figures.torque_speed_figure(limited, free, wind, drawn_map,
                                                        envelope, paper)
    if free:
        out["fig10"] = cycle_figures.power_flow_figure(
            dict(sorted(free.items(), key=lambda kv: KINDS[kv[0]].objective != "electrical")),
            wind)
    return out


def winding_limit(manifest: dict | None) -> float | None:
    """The drive's winding limit [degC] the sweep flew with (its manifest's bound values)."""
    value = flown_bounds(manifest).get("winding_temperature_limit")
    return float(value) if value is not None else None


def fig3(traj: pd.DataFrame | None, summary: pd.DataFrame,
         winding_limit_c: float | None = None,
         wind: float = FIG3_WIND_M_S) -> tuple[object, str | None]:
    """The Fig. 3 analogue (:data:`FIG3_KIND` at ``wind``, the paper's
    :data:`FIG3_WIND_M_S` for the paper's system), or (None, why not)."""
    cycle, why = _cycle(traj, summary, FIG3_KIND, wind)
    if cycle is None:
        return None, why
    return cycle_figures.cycle_figure(
        cycle, f"electrically optimized, constrained, {wind:g} m/s, "
               f"period {cycle.period_s:.2f} s", winding_limit_c), None
