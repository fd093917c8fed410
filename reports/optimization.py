"""Section 4 of the report: the optimized cycles (Table II, Figs. 8, 9, 10, 3, claims).

Reads ``optimize_out/summary.parquet`` (one row per scenario, with solver status),
``trajectories.parquet`` (every collocation point, a ``scenario`` column),
``manifest.json`` and ``claims.csv`` (docs/schemas.md §5). A scenario that did not
converge is shown as failed with its status and is never plotted or compared.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from kernel.errors import InputError
from optimize.kinds import KINDS, LABELS
from optimize.sweep_folder import (
    SUMMARY_REQUIRED,
    TRAJECTORY_COLUMNS,
    domain_excursions,
    domain_line,
    on_bounds,
)
from reports import cycle_figures
from reports.failed import failed_rows, failure_text
from reports.inputs import InputLog
from reports.tables import fmt, frame_table

#: Fig. 3: electrically optimized, constrained cycle at 5.5 m/s.
FIG3_KIND, FIG3_WIND_M_S = "elec-lim", 5.5


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


def closed_cycle(rows: pd.DataFrame) -> pd.DataFrame:
    """A cycle's collocation points sorted by time, closed at t = 0 by periodicity.

    The points sit at ``time_s`` in ``(0, T]``; the state at 0 equals the state at
    T, so the last point is repeated at ``time_s = 0`` with quadrature weight 0.
    """
    rows = rows.sort_values("time_s")
    first = rows.iloc[[-1]].copy()
    first["time_s"] = 0.0
    first["weight"] = 0.0
    return pd.concat([first, rows], ignore_index=True)


def _trajectory(traj: pd.DataFrame | None, summary: pd.DataFrame, kind: str,
                wind: float) -> tuple[pd.DataFrame | None, str | None]:
    """The closed cycle of a converged scenario (:func:`closed_cycle`), or (None, why not)."""
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
    return closed_cycle(rows), None


def run_rows(manifest: dict, fit_model_sha256: str | None) -> list[tuple[str, str]]:
    """How the sweep ran (executor, wall time, convergence, drive model, options) as pairs.

    The drive model the sweep used is compared with the fitted model of the
    report's section 3 (canonical SHA-256, docs/schemas.md §3).
    """
    rows = []
    for key in ("executor", "wall_time_s", "converged", "failed"):
        if key in manifest:
            value = manifest[key]
            text = fmt(value, 1) if isinstance(value, float) else (
                ", ".join(map(str, value)) or "none" if isinstance(value, list) else str(value))
            rows.append((key, text))
    drive = manifest.get("drive_model")
    if isinstance(drive, dict):
        rows.append(("drive model", f"{drive.get('name', '?')} ({drive.get('path', '?')})"))
        used = drive.get("model_sha256")
        if used and fit_model_sha256:
            same = "yes" if used == fit_model_sha256 else "NO: the sweep used another model"
            rows.append(("same model as section 3", same))
    options = manifest.get("options")
    if isinstance(options, dict):  # {group: {option: value}}
        for group, values in options.items():
            items = values.items() if isinstance(values, dict) else [(group, values)]
            rows.extend((f"option {k}", str(v)) for k, v in items)
    return rows


def cut_in_rows(manifest: dict) -> list[dict]:
    """Cut-in wind speeds (net electrical power crosses zero) found by the sweep's search."""
    rows = []
    for c in manifest.get("cut_in") or []:
        if isinstance(c, dict):
            lo, hi = c.get("bracket_lo_m_s"), c.get("bracket_hi_m_s")
            rows.append({"kind": str(c.get("kind", "")),
                         "label": LABELS.get(str(c.get("kind")), ""),
                         "cut_in": fmt(c.get("cut_in_m_s"), 2),
                         "bracket": f"{fmt(lo, 3)} - {fmt(hi, 3)}" if lo is not None else "",
                         "status": str(c.get("status", ""))})
    return rows


def trust_tables(manifest: dict) -> dict:
    """The sweep's trust checks (mesh refinement, independent simulation) as tables."""
    trust = manifest.get("trust") if isinstance(manifest.get("trust"), dict) else {}
    out = {}
    for name in ("mesh", "simulation"):
        records = [r for r in trust.get(name) or [] if isinstance(r, dict)]
        out[name] = frame_table(pd.DataFrame(records)) if records else None
    return out


def claims_rows(claims: pd.DataFrame) -> list[dict]:
    """Rows of claims.csv (statement, paper, ours, verdict, note) as plain strings."""
    columns = ("claim_id", "statement", "paper", "ours", "verdict", "note")
    return [{c: str(r.get(c, "")) for c in columns} for r in claims.to_dict(orient="records")]


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


def optimization_section(log: InputLog, optimize: Path,
                         grid: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
                         fit_model_sha256: str | None = None) -> dict:
    """Section 4 context.

    Parameters
    ----------
    log : InputLog
    optimize : Path
        The ``bench optimize`` output folder.
    grid : tuple or None
        (speed_rpm, torque_nm, eta) of the efficiency map, beneath Fig. 9.
    fit_model_sha256 : str, optional
        Canonical hash of the fitted model, to check the sweep used it.

    Returns
    -------
    dict
        ``table_ii``, ``n_failed``, ``scenarios`` (full summary table), ``fig8a``,
        ``fig8b``, ``fig9``, ``fig10``, ``fig3`` (each markup or None), ``domain``
        (:func:`domain_rows`), ``notes``
        (why a figure is absent), ``claims``, ``run``, ``cut_in``, ``trust``,
        ``manifest``, ``missing``, ``bounds`` (:func:`bound_rows`), ``system``
        (name, hash and file text from the manifest, or None), ``kite_limits``
        (:func:`kite_limits_line`), ``local_optima`` (the sweep's re-solves, one line each).
    """
    start = len(log.missing)
    optimize = Path(optimize)
    summary_path = optimize / "summary.parquet"
    summary = log.parquet(summary_path, SUMMARY_REQUIRED)
    traj = log.parquet(optimize / "trajectories.parquet", TRAJECTORY_COLUMNS)
    manifest = log.json(optimize / "manifest.json")
    claims = log.csv(optimize / "claims.csv", ("statement", "paper", "ours", "verdict"))
    out: dict = {"notes": {"fig9": None, "fig3": None}, "manifest": manifest,
                 "table_ii": None, "n_failed": 0, "n_scenarios": 0, "scenarios": None,
                 "fig8a": None, "fig8b": None, "fig9": None, "fig10": None, "fig3": None,
                 "fig9_periods": [], "fig9_wind": None, "bounds": [], "failed": [],
                 "domain": None}
    out["claims"] = claims_rows(claims) if claims is not None else None
    out["run"] = run_rows(manifest, fit_model_sha256) if manifest is not None else []
    out["cut_in"] = cut_in_rows(manifest) if manifest is not None else []
    out["trust"] = trust_tables(manifest or {})
    out["system"] = (manifest or {}).get("system")
    out["kite_limits"] = kite_limits_line(manifest or {})
    out["local_optima"] = [str(n) for n in (manifest or {}).get("local_optima") or []]
    if summary is not None and len(summary):
        s = normalized_summary(summary, summary_path)
        out["table_ii"] = table_ii(s)
        out["n_failed"] = int((~s["ok"]).sum())
        out["failed"] = failed_rows(summary)
        out["n_scenarios"] = len(s)
        out["scenarios"] = frame_table(summary)
        out["bounds"] = bound_rows(summary)
        out["domain"] = domain_rows(summary)
        out["fig8a"] = cycle_figures.power_vs_wind_figure(
            s, "avg_p_elec_w", "fig8a", "Average generated ELECTRICAL power (Fig. 8a)")
        out["fig8b"] = cycle_figures.power_vs_wind_figure(
            s, "avg_p_mech_w", "fig8b", "Average generated MECHANICAL power (Fig. 8b)")
        # Figs. 9 and 10: unconstrained cycles at the highest wind of the sweep (the
        # paper's most extreme case, 10 m/s on the default grid)
        wind = float(s["wind_speed_m_s"].max())
        out["fig9_wind"] = fmt(wind, sig=3)
        cycles, notes = {}, []
        for kind in ("elec-free", "mech-free"):
            t, why = _trajectory(traj, s, kind, wind)
            if t is None:
                notes.append(why)
            else:
                cycles[kind] = t
        if cycles:
            # paper order: Fig. 9 (b) mechanical, (c) electrical; Fig. 10 (a) electrical
            mech_first = dict(sorted(cycles.items(),
                                     key=lambda kv: KINDS[kv[0]].objective != "mechanical"))
            out["fig9"] = cycle_figures.torque_speed_figure(mech_first, wind, grid)
            out["fig10"] = cycle_figures.power_flow_figure(cycles, wind)
            out["fig9_periods"] = [
                {"label": LABELS[k], "period_s": fmt(t["time_s"].max(), 2)}
                for k, t in cycles.items()]
        if notes:
            out["notes"]["fig9"] = "; ".join(notes)
        t, why = _trajectory(traj, s, FIG3_KIND, FIG3_WIND_M_S)
        if t is None:
            out["notes"]["fig3"] = why
        else:
            period = float(t["time_s"].max())
            out["fig3"] = cycle_figures.cycle_figure(
                t, period, f"electrically optimized, constrained, {FIG3_WIND_M_S:g} m/s, "
                f"period {period:.2f} s")
    out["missing"] = list(dict.fromkeys(log.missing[start:]))
    return out
