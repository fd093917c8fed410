"""The report's campaign section: sessions, instruments and metadata, points per
quadrant, rejected windows, clocks (the store of ``bench ingest``, docs/schemas.md §2).

Like every section module, it reads what it needs through an
:class:`reports.inputs.InputLog` and returns a plain dict for the template, whose
``missing`` lists the input files that were absent. Strings from logs and metadata stay
plain strings here; the template escapes them.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from bench.store.damage import check_store
from bench.store.manifest import kind_files as store_files
from bench.store.manifest import read_manifest
from bench.store.read import STORE_REPAIR, read_points, read_rejected
from kernel.drive import BOX_KEYS
from kernel.errors import InputError
from kernel.files import check_columns
from reports import drive_figures
from reports.inputs import InputLog
from reports.tables import flatten, fmt, missing_since

POINT_COLUMNS = ("session_id", "quadrant", "speed_rpm", "torque_nm", "p_mech_w", "p_elec_w")
REJECTED_COLUMNS = ("session_id", "t_start_s", "t_end_s", "reason")
READERS = {"points": read_points, "rejected": read_rejected}


def _store_kind(log: InputLog, store: Path, kind: str, manifest: dict | None,
                required: tuple[str, ...]) -> pd.DataFrame | None:
    """The ``kind`` tables the store's manifest lists (never files it does not list), read
    by the store's reader after the store's own check (``bench store check``)."""
    files = [] if manifest is None else list(store_files(store, kind, manifest).values())
    if files:
        damage = check_store(store, manifest)
        if damage.damaged:
            raise InputError(store, "damaged store: " + "; ".join(damage.lines()[:3]),
                             expected=STORE_REPAIR)
    frame = log.read_files(files, str(Path(store) / kind / "*.parquet"),
                           lambda: READERS[kind](store))
    if frame is not None:
        check_columns(frame.columns, required, store / kind)
    return frame


def campaign_section(log: InputLog, store: Path) -> dict:
    """The campaign section: sessions, instruments, metadata, points, rejections, clocks.

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
    manifest = log.read(store, "manifest.json", read_manifest, whole=False)
    points = _store_kind(log, store, "points", manifest, POINT_COLUMNS)
    rejected = _store_kind(log, store, "rejected", manifest, REJECTED_COLUMNS)
    sessions = []
    if manifest is not None:
        for sid, entry in sorted(manifest["sessions"].items()):
            sessions.append(_session_row(str(sid), entry if isinstance(entry, dict) else {}))
    quadrant_counts = {"motor": 0, "generator": 0}
    figure = None
    if points is not None and len(points):
        counts = points["quadrant"].astype(str).value_counts()
        quadrant_counts = {q: int(counts.get(q, 0)) for q in ("motor", "generator")}
        figure = drive_figures.operating_points_figure(points)
    reasons = rejected_reasons(rejected, manifest)
    return {
        "sessions": sessions,
        "totals": {
            "sessions": len(sessions),
            "points": int(len(points)) if points is not None else None,
            **quadrant_counts,
            "rejected": sum(r["count"] for r in reasons if r["what"] == "window"),
            "rejected_cycles": sum(r["count"] for r in reasons if r["what"] == "cycle"),
        },
        "rejected_reasons": reasons,
        "beyond_rating": beyond_rating(points, manifest),
        "figure": figure,
        "missing": missing_since(log, start),
        "points": points,
        "manifest": manifest,
    }


def rejected_reasons(rejected: pd.DataFrame | None, manifest: dict | None) -> list[dict]:
    """Rejections by reason, largest first: ``{"reason", "what", "count"}``, ``what``
    ``"cycle"`` for a cycle run's rejected cycles and ``"window"`` for the steady-state
    windows of the other sessions; from the store's ``rejected/`` or, without it, the
    manifest's counts."""
    entries = {str(k): e for k, e in (manifest or {}).get("sessions", {}).items()
               if isinstance(e, dict)}
    cycle_runs = {sid for sid, e in entries.items() if e.get("kind") == "cycle_run"}
    agg: dict[tuple[str, str], int] = {}
    if rejected is not None and len(rejected):
        what = rejected["session_id"].astype(str).isin(cycle_runs).map({True: "cycle",
                                                                         False: "window"})
        for (reason, kind), n in rejected.groupby([rejected["reason"].astype(str), what]).size(
                ).items():
            agg[(reason, kind)] = int(n)
    else:
        for sid, entry in entries.items():
            kind = "cycle" if sid in cycle_runs else "window"
            for r, n in (entry.get("rejected") or {}).items():
                agg[(str(r), kind)] = agg.get((str(r), kind), 0) + int(n)
    return [{"reason": r, "what": w, "count": n}
            for (r, w), n in sorted(agg.items(), key=lambda x: -x[1])]


#: a point this share above a stated limit is beyond it (a point run at the limit reads
#: a little above it: its window's scatter) [-]
BEYOND_SHARE = 0.01


def beyond_rating(points: pd.DataFrame | None, manifest: dict | None) -> list[str]:
    """Sentences on operating points beyond the drive rating their sessions state
    (``drive.toml``/``session.toml``: the speed and torque limits,
    :data:`kernel.drive.BOX_KEYS`, drum side):
    how many, how far, under which rating."""
    if points is None or not len(points) or manifest is None:
        return []
    out = []
    for key, column, unit in zip(BOX_KEYS, ("speed_rpm", "torque_nm"), ("rpm", "N m"),
                                 strict=True):
        limit = {str(sid): float(e["drive"][key]) for sid, e in manifest["sessions"].items()
                 if isinstance(e, dict) and isinstance(e.get("drive"), dict)
                 and isinstance(e["drive"].get(key), int | float)}
        stated = points["session_id"].astype(str).map(limit)
        value = points[column].astype(float).abs()
        over = value > stated * (1 + BEYOND_SHARE)
        if not over.any():
            continue
        worst = int((value / stated).where(over).idxmax())
        out.append(f"{int(over.sum())} of {len(points)} operating points lie more than "
                   f"{100 * BEYOND_SHARE:g} % beyond the drive's "
                   f"stated {key} ({fmt(stated[worst], 0)} {unit} at the drum, session "
                   f"{points['session_id'][worst]}): up to {fmt(value[worst], 0)} {unit}, "
                   f"{value[worst] / stated[worst]:.1f} x the rating. The bench ran the drive "
                   "beyond the limits the optimization flies; the map and the fit cover those "
                   "points, the constrained cycles (*-lim) stay within the rating")
    return out


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
        "metadata": flatten(meta),
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
