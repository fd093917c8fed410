"""The output folder of ``bench optimize`` (docs/schemas.md §5): its schema, its one writer
and its readers, used by the optimize stage, ``bench aep``, ``bench size``, the report
and the tests.

* ``summary.parquet``: one row per scenario, failed ones included with their solver
  status and NaN metrics (:data:`SUMMARY_COLUMNS`);
* ``trajectories.parquet``: every collocation point of every converged scenario (states,
  controls, drive quantities) with ``scenario``, ``kind`` and the wind speed;
* ``manifest.json``: the sweep's record (provenance header, wind list, kinds, drive model,
  system, options, executor, cut-in searches, trust checks);
* ``claims.csv``: the comparison with the paper (:mod:`optimize.analysis.claims`);
* ``power_model.json``: the losses the sweep flew with, when no file holds them as flown
  (carried to the system's rating, or given to the Python API as an object).

Every Parquet field carries its unit in the field metadata (``{"unit": ...}``), from the
unit suffix of the column name (:func:`kernel.units.unit_of`). This module imports only the
kernel: the readers of later stages take it without the optimizer.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from kernel.drive import Drive
from kernel.files import (
    file_sha256,
    read_csv,
    read_document,
    read_parquet,
    write_csv,
    write_json,
    write_parquet,
)
from kernel.output_folder import check_output_folder, output_folder
from kernel.provenance import Provenance

SCHEMA_NAME = "drivebench.optimize"
#: the manifest's layout: 2 records the bounds flown as the system's ``sections`` (the
#: ``[drive]`` in force) and their ``bound_values``, no ``options.limits``; 3 the drive in
#: force once, as ``sections.drive`` (no ``drive_limits``, no ``drive.rating``)
SCHEMA_VERSION = 3
SUMMARY_FILE, TRAJECTORIES_FILE = "summary.parquet", "trajectories.parquet"
MANIFEST_FILE, CLAIMS_FILE, MODEL_FILE = "manifest.json", "claims.csv", "power_model.json"
#: the seed's optimum, the start of a later sweep of the same system (``--start``)
START_FILE = "start.npz"
#: files by which an optimize output folder written before run ids is known
MARKERS = (SUMMARY_FILE, MANIFEST_FILE)

#: summary columns, in order, with their meaning (unit from the name)
SUMMARY_COLUMNS: dict[str, str] = {
    "scenario": "scenario name, kind and wind speed",
    "kind": "elec-lim | elec-free | mech-lim | mech-free",
    "objective": "electrical | mechanical (the average power maximized)",
    "drive_limits": "the drive's speed and torque limits applied (manifest sections.drive)",
    "wind_speed_m_s": "wind speed at 100 m",
    "success": "final solve converged",
    "status": "IPOPT return status of the final solve",
    "result_check": "the physical check of a converged optimum (power against the Loyd-type "
    "bound, collocation error and periodicity of a finer re-integration): 'passed', or "
    "'failed: <reasons>' (then success is false whatever the solver said); '' when not "
    "checked",
    "iterations": "IPOPT iterations of the final solve",
    "intermediate_points": "converged intermediate points on the way from the final solve's "
    "start to this scenario (step control: the wind speed, objective and drive limits moved "
    "part of the way; not results), 0 when it was solved directly",
    "intermediate_iterations": "IPOPT iterations on that way besides the final solve's (the "
    "intermediate points and the capped tries whose step was halved)",
    "wall_time_s": "wall time of the final solve",
    "attempts": "solver runs (retries included)",
    "total_wall_time_s": "wall time of all runs of this scenario",
    "warm_source": "scenario the final solve was warm-started from, or 'cold start'",
    "depth": "solves before this one along its starts: 0 for a cold start or the stored "
             "guess, else one more than its warm_source's at the time",
    "chain": "the task that solved it: the index of its step in the start graph",
    "n_intervals": "collocation intervals of the mesh this row's result is on: the sweep's "
    "(manifest) unless the last retry solved it on a finer one (warm_source says so); 0 "
    "when no solve returned a result",
    "resolved_from": "where this one was solved again from, comma-separated: neighbouring "
    "scenarios of the same kind, because its average power or period sat off the kind's "
    "smooth curve, or its own optimum held at another period by the period scan "
    "('mech-free-10.0 held at 45 s'); '' when it was not",
    "periods_scanned": "periods the period scan held this scenario at (0: not scanned)",
    "resolve_gain_w": "how much more power [W] the kept re-solve's objective gives than the "
    "first optimum (0: the first was the better; NaN: not re-solved)",
    "active_bounds": "bounds the optimum sits on, comma-separated: period_min, period_max, "
    "tether_length_min, tether_length_max, ground_clearance, airspeed_min, airspeed_max, "
    "tether_force_limit, reel_acceleration_limit, reel_jerk_limit, speed_limit, torque_limit, "
    "envelope_limit, p_elec_limit, winding_temperature_limit ('' for none)",
    "bound_limited": "an optimum on a bound the system did not mean to bind (period or tether "
    "length range, the winding temperature's range): the optimum is the bound's, not the "
    "kite's",
    "period_s": "cycle period",
    "avg_p_elec_w": "average electrical power (negative = generated)",
    "avg_p_mech_w": "average mechanical power (negative = generated)",
    "e_elec_j": "net electrical energy per cycle (negative = generated)",
    "e_mech_j": "net mechanical energy per cycle (negative = generated)",
    "peak_speed_rpm": "largest |motor speed| (drum speed times the gear ratio)",
    "peak_torque_nm": "largest |torque| the drive delivers at its shaft (tether torque at the "
                      "motor plus the drivetrain's acceleration torque)",
    "peak_reel_acceleration_m_s2": "largest |tether acceleration| (reel acceleration)",
    "peak_winding_temperature_c": "highest winding temperature over the cycle, its cyclic "
    "steady state (NaN without a thermal model in the OCP)",
    "thermal_margin_k": "the drive's winding limit minus that peak (NaN without a thermal "
    "model in the OCP)",
    "p_elec_max_w": "largest electrical power (peak drawn from the grid)",
    "p_elec_min_w": "smallest electrical power (peak generated, negative)",
    "tether_length_min_m": "shortest tether length",
    "tether_length_max_m": "longest tether length",
    "altitude_min_m": "lowest altitude above ground",
    "altitude_max_m": "highest altitude above ground",
    "periodicity_error": "largest scaled residual of the periodicity constraints [-]",
    "max_violation": "largest scaled constraint violation [-]",
    "slack_fraction": "fraction of the cycle time with zero tether tension (slack tether) [-]",
    "outside_domain_time_frac": "share of the cycle time outside the drive model's validity "
                                "domain (its measured envelope per quadrant) [-]; NaN when "
                                "the model has no domain",
    "outside_domain_loss_frac": "share of the cycle's drive loss energy (P_elec - P_mech) "
                                "at points outside that domain, where the model extrapolates "
                                "[-]; NaN when the model has no domain",
    "outside_worst_speed_rpm": "drum speed of the cycle point farthest outside the domain",
    "outside_worst_torque_nm": "drum torque of the cycle point farthest outside the domain",
    "outside_worst_distance": "its distance to the domain in units of the drive's speed "
                              "and torque limits [-]; 0 when the cycle stays inside",
}
#: the columns every reader of ``summary.parquet`` relies on (``bench aep``, ``bench size``,
#: ``bench report``); the others are read where present
SUMMARY_REQUIRED = ("scenario", "kind", "objective", "drive_limits", "wind_speed_m_s",
                    "success", "status", "avg_p_elec_w", "avg_p_mech_w", "period_s",
                    "peak_speed_rpm", "peak_torque_nm")
#: the columns of ``claims.csv`` a reader needs (:mod:`optimize.analysis.claims` writes more)
CLAIMS_COLUMNS = ("statement", "paper", "ours", "verdict")
#: the columns of ``trajectories.parquet`` its readers rely on (the energy stage's cycle
#: averages, the report's cycle figures); the file holds every state and control besides
TRAJECTORY_COLUMNS = ("scenario", "kind", "wind_speed_m_s", "time_s", "weight", "l_m",
                      "speed_rpm", "torque_nm", "p_elec_w", "p_mech_w")
#: keys of the Parquet files' schema metadata recording the system
SYSTEM_META_KEYS = ("drivebench.system_name", "drivebench.system_sha256",
                    "drivebench.system_toml")
_EXPECTED = "the output of `bench optimize` (docs/schemas.md §5)"


# ------------------------------------------------------------------ writing
def system_metadata(system: dict | None) -> dict[str, str]:
    """Parquet schema metadata recording the system (``System.record()``) under
    :data:`SYSTEM_META_KEYS`: name, hash and the system file's text."""
    if system is None:
        return {}
    return {key: str(system[field]) for key, field in
            zip(SYSTEM_META_KEYS, ("name", "sha256", "text"), strict=True)}


def write_sweep_folder(out: Path, provenance: Provenance, *, summary: pd.DataFrame,
                       trajectories: pd.DataFrame, manifest: dict, system: dict | None,
                       claims: pd.DataFrame | None = None,
                       carried_model: Any = None,
                       start: Callable[[Path], Path] | None = None) -> dict[str, Path]:
    """Write the sweep's files into ``out``, all or none (:mod:`kernel.output_folder`).

    Parameters
    ----------
    out : Path
        The output folder.
    provenance : Provenance
        The run's provenance header (written into the manifest and ``run.json``).
    summary, trajectories : DataFrame
        ``summary.parquet`` (columns :data:`SUMMARY_COLUMNS`) and ``trajectories.parquet``.
    manifest : dict
        The manifest's content after its schema and provenance keys.
    system : dict or None
        ``System.record()``, recorded in the Parquet files' metadata.
    claims : DataFrame, optional
        ``claims.csv`` (none written without: the folder is replaced whole).
    carried_model : PowerModel, optional
        The losses the sweep flew with, when no power-model file named them (for ``bench
        aep``); written as ``power_model.json``, whose final path and file hash the
        manifest's ``drive_model`` then names.
    start : callable, optional
        ``start(path)`` writes the sweep's start file there (:data:`START_FILE`).

    Returns
    -------
    dict
        File name key (``summary``, ``trajectories``, ``power_model``, ``claims``,
        ``start``, ``manifest``) -> its path in ``out``.
    """
    with output_folder(out, "optimize", MARKERS, provenance=provenance) as stage:
        meta = system_metadata(system)
        files = {"summary": write_parquet(stage / SUMMARY_FILE, summary,
                                          descriptions=SUMMARY_COLUMNS, metadata=meta),
                 "trajectories": write_parquet(stage / TRAJECTORIES_FILE, trajectories,
                                               metadata=meta)}
        if carried_model is not None:
            files["power_model"] = write_json(stage / MODEL_FILE,
                                              carried_model.to_dict(), non_finite="error")
            manifest = {**manifest, "drive_model": {
                **manifest["drive_model"], "path": str(Path(out).absolute() / MODEL_FILE),
                "file_sha256": file_sha256(files["power_model"])}}
        if claims is not None:
            files["claims"] = write_csv(stage / CLAIMS_FILE, claims)
        if start is not None:
            files["start"] = start(stage / START_FILE)
        doc = {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION,
               "provenance": provenance.header(), **manifest,
               "files": {k: Path(v).name for k, v in files.items()}}
        files["manifest"] = write_json(stage / MANIFEST_FILE, doc)
    return {k: Path(out) / Path(v).relative_to(stage) for k, v in files.items()}


# ------------------------------------------------------------------ reading back
def field_units(path: Path) -> dict[str, str]:
    """Column -> unit recorded in a Parquet file's field metadata."""
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}


def read_summary(path: Path) -> pd.DataFrame:
    """``summary.parquet`` with the columns of :data:`SUMMARY_REQUIRED` checked."""
    return read_parquet(path, SUMMARY_REQUIRED, expected=_EXPECTED)


def read_trajectories(folder: Path, columns: tuple[str, ...] | None = None) -> pd.DataFrame:
    """``trajectories.parquet`` of ``folder`` (``columns``: only those of
    :data:`TRAJECTORY_COLUMNS`; default all)."""
    return read_parquet(Path(folder) / TRAJECTORIES_FILE, columns or TRAJECTORY_COLUMNS,
                        columns, expected=_EXPECTED)


def read_manifest(folder: Path) -> dict:
    """The sweep's ``manifest.json``, its schema checked."""
    return read_document(Path(folder) / MANIFEST_FILE, SCHEMA_NAME, expected=_EXPECTED)


def sweep_drive(manifest: dict, folder: Path | None = None) -> Drive | None:
    """The ``[drive]`` in force a sweep flew, its manifest's ``sections.drive`` read by
    :meth:`kernel.drive.Drive.from_dict` (the one reader of the drive's dict form); None
    when the manifest records none (an older ``bench optimize``'s).

    Raises
    ------
    InputError
        A ``sections.drive`` that is not a drive (naming the manifest and the key).
    """
    drive = (manifest.get("sections") or {}).get("drive")
    if drive is None:
        return None
    where = None if folder is None else Path(folder) / MANIFEST_FILE
    return Drive.from_dict(drive, where, "sections.drive")


def read_claims(folder: Path) -> pd.DataFrame:
    """The sweep's ``claims.csv`` (the comparison with the paper)."""
    return read_csv(Path(folder) / CLAIMS_FILE, CLAIMS_COLUMNS, expected=_EXPECTED)


def read_sweep_folder(folder: Path) -> tuple[pd.DataFrame, dict]:
    """The summary and the manifest of a whole optimize folder
    (:func:`kernel.output_folder.check_output_folder` first)."""
    folder = Path(folder)
    check_output_folder(folder)
    return read_summary(folder / SUMMARY_FILE), read_manifest(folder)


# ------------------------------------------------------------------ the summary in words
def domain_excursions(summary: pd.DataFrame) -> pd.DataFrame | None:
    """The converged scenarios whose cycle leaves the drive model's validity domain.

    None when the summary has no ``outside_domain_time_frac`` column (an older sweep) or
    the model had no domain (all NaN); an empty frame when every cycle stays inside.
    """
    if "outside_domain_time_frac" not in summary.columns:
        return None
    ok = summary[summary["success"].astype(bool)]
    frac = ok["outside_domain_time_frac"].astype(float)
    if ok.empty or frac.isna().all():
        return None
    return ok[frac > 0]


#: what the scenarios of :func:`remesh_lines` are, in words (the log's and the report's)
FINER_MESH_HEAD = ("solved on a finer mesh (the sweep's mesh is too coarse for their cycle: the "
                   "result check rejected it there; each stands on its own mesh)")


def remesh_lines(summary: pd.DataFrame) -> list[str]:
    """One line per scenario whose optimum stands on a finer mesh than the sweep's (the
    last retry, :func:`optimize.service.retry.retry_on_finer_mesh`); none for a summary
    written before ``n_intervals`` existed."""
    if "n_intervals" not in summary.columns:
        return []
    return [f"{r.scenario}: on {r.n_intervals} intervals" for r in summary.itertuples(index=False)
            if r.success and r.warm_source == f"{r.scenario} on {r.n_intervals} intervals"]


def on_bounds(summary: pd.DataFrame) -> pd.DataFrame:
    """The converged scenarios on a bound or with a slack tether (none in a summary written
    before ``active_bounds``, ``bound_limited`` and ``slack_fraction`` existed)."""
    if not {"active_bounds", "bound_limited", "slack_fraction"} <= set(summary.columns):
        return summary.iloc[:0]
    ok = summary[summary["success"].astype(bool)]
    slack = ok["slack_fraction"].astype(float)
    return ok[(ok["active_bounds"].astype(str) != "") | (np.isfinite(slack) & (slack > 0))]


def domain_line(r: Any) -> str:
    """One scenario (a summary row) outside the validity domain, in words."""
    lost = getattr(r, "outside_domain_loss_frac", math.nan)  # absent before it existed
    losses = f", {100 * lost:.1f} % of its drive losses" if math.isfinite(lost) else ""
    return (f"{r.scenario}: {100 * r.outside_domain_time_frac:.1f} % of the cycle time{losses} "
            f"outside the drive model's validity domain; worst at "
            f"{r.outside_worst_speed_rpm:.0f} rpm, "
            f"{r.outside_worst_torque_nm:.1f} N m (distance {r.outside_worst_distance:.3f} of "
            "the drive rating)")


def bound_line(r: Any) -> str:
    """One scenario (a summary row) on a bound or with a slack tether, in words."""
    note = (" BOUND-LIMITED: the optimum is the bound's, not the kite's"
            if r.bound_limited else "")
    return (f"{r.scenario}: on {r.active_bounds or 'no bound'}; slack tether "
            f"{100 * r.slack_fraction:.1f} % of the cycle{note}")


def domain_lines(summary: pd.DataFrame) -> list[str]:
    """One line per converged scenario whose cycle leaves the model's validity domain."""
    rows = domain_excursions(summary)
    return [] if rows is None else [domain_line(r) for r in rows.itertuples(index=False)]


def bound_lines(summary: pd.DataFrame) -> list[str]:
    """One line per converged scenario on a bound or with a slack tether."""
    return [bound_line(r) for r in on_bounds(summary).itertuples(index=False)]


#: converged wind speeds a kind needs for the local-optimum check, which compares each
#: optimum with the curve through its neighbours (:mod:`optimize.service.local_optima`)
MIN_CURVE_SPEEDS = 3
#: what the kinds of :func:`unchecked_lines` are, in words (the log's and the report's)
UNCHECKED_HEAD = (f"local optima not checked (fewer than {MIN_CURVE_SPEEDS} converged wind "
                  "speeds of the kind: the check compares neighbouring speeds, so each optimum "
                  "there may be a local one; --period-scan N looks for others along the "
                  "period; benchmarks/README.md, AP2's local optima)")


#: the head of :func:`unchecked_lines` when a period scan was asked and held none of them
UNCHECKED_SCAN_HEAD = (f"local optima not checked (fewer than {MIN_CURVE_SPEEDS} converged "
                       "wind speeds of the kind, and the period scan held none of their "
                       "optima: every period it would hold lies outside the period bounds or "
                       "within 15 % of the optimum's own)")


def unchecked_head(period_scan: int = 0, period_bounds_s: tuple[float, float] | None = None
                   ) -> str:
    """The head of :func:`unchecked_lines`: with a period scan asked (``--period-scan``
    > 0), that it held nothing there and the bounds to widen, not the option to give."""
    if period_scan <= 0:
        return UNCHECKED_HEAD
    span = ("" if period_bounds_s is None else
            f" (now {period_bounds_s[0]:g} to {period_bounds_s[1]:g} s)")
    return (f"{UNCHECKED_SCAN_HEAD}; widen [bounds] period_min_s, period_max_s{span} for "
            f"--period-scan {period_scan} to hold other periods")


def unchecked_lines(summary: pd.DataFrame) -> list[str]:
    """One line per kind whose converged scenarios are too few for the local-optimum check
    and were not all period-scanned (none for a summary without ``kind``)."""
    if "kind" not in summary.columns:
        return []
    ok = summary[summary["success"].astype(bool)]
    if "periods_scanned" in ok.columns:
        scanned = ok.groupby("kind", sort=False)["periods_scanned"].min() > 0
        ok = ok[~ok["kind"].map(scanned).astype(bool)]
    return [f"{kind}: {n} converged wind speed{'s' if n > 1 else ''}"
            for kind, n in ok.groupby("kind", sort=False).size().items() if n < MIN_CURVE_SPEEDS]


def resolve_lines_of(summary: pd.DataFrame) -> list[str]:
    """One line per scenario re-solved from a neighbour or by the period scan (summary
    ``resolved_from``)."""
    if "resolved_from" not in summary.columns:
        return []
    lines = []
    for r in summary.itertuples(index=False):
        if r.resolved_from:
            gain = (f"better by {r.resolve_gain_w:.1f} W, kept" if r.resolve_gain_w > 0
                    else "no better optimum found")
            lines.append(f"{r.scenario}: re-solved from {r.resolved_from}: {gain}")
    return lines
