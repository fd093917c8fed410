"""The drive rating a fit uses: from the command line, the store manifest, or the data.

Order per key (``nominal_power_w``, ``max_speed_rpm``, ``max_torque_nm``; the
torque-speed envelope, when the campaign states one, comes from the manifest only):

1. a ``bench fit`` option (``--nominal-power-w`` ...);
2. the store manifest: the ``drive`` that ``bench ingest`` recorded for the
   sessions whose points are fitted (from ``drive.toml`` / ``session.toml``);
   sessions that state different values are an error;
3. the measured maxima (largest |P_mech|, |speed|, torque among the points), said
   so in the rating's ``source`` and in a note: a stand-in, not a rating.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from bench.store.manifest import read_manifest
from kernel.drive import DRIVE_KEYS, ENVELOPE_KEYS, Drive
from kernel.errors import InputError


def _from_manifest(store: Path, session_ids: list[str]) -> tuple[dict, dict]:
    """Rating keys the manifest states for these sessions, and where each came from."""
    manifest = read_manifest(store)
    values: dict[str, float] = {}
    where: dict[str, str] = {}
    notes: set[str] = set()
    for sid in session_ids:
        drive = (manifest["sessions"].get(sid) or {}).get("drive") or {}
        for key in (*DRIVE_KEYS, *ENVELOPE_KEYS):
            if key not in drive:
                continue
            origin = str((drive.get("sources") or {}).get(key, f"manifest, session {sid}"))
            if key in values and values[key] != drive[key]:
                raise InputError(store / "manifest.json",
                                 f"sessions disagree on the drive rating {key}: "
                                 f"{values[key]} ({where[key]}) vs {drive[key]} ({origin})",
                                 column=key, expected="one drive per fit (one drive.toml per "
                                 "campaign, or the same values in each session.toml)")
            values[key] = float(drive[key]) if key in DRIVE_KEYS else drive[key]
            where.setdefault(key, origin)
        if drive.get("source"):
            notes.add(str(drive["source"]))
    return values, {"where": where, "notes": sorted(notes)}


def measured_maxima(frame: pd.DataFrame) -> dict[str, float]:
    """Largest |P_mech| [W], |speed| [rpm] and torque [N m] among the points."""
    return {"nominal_power_w": float(np.max(np.abs(frame["p_mech_w"]))),
            "max_speed_rpm": float(np.max(np.abs(frame["speed_rpm"]))),
            "max_torque_nm": float(np.max(frame["torque_nm"]))}


def resolve_drive(store: str | Path, frame: pd.DataFrame,
                  overrides: dict[str, float] | None = None) -> tuple[Drive, list[str]]:
    """The rating the fit uses (see the module docstring) and notes for the summary.

    Parameters
    ----------
    store : str or Path
        The store (its ``manifest.json`` may be missing: then no manifest rating).
    frame : pandas.DataFrame
        The fitted points (``session_id``, ``speed_rpm``, ``torque_nm``, ``p_mech_w``).
    overrides : dict, optional
        Rating keys given on the command line.

    Returns
    -------
    rating : kernel.drive.Drive
        With ``source`` saying where each key came from.
    notes : list of str
        A line for each key that is a measured stand-in.

    Raises
    ------
    InputError
        Sessions of the store that state different ratings; a non-positive override.
    """
    store = Path(store)
    values, info = _from_manifest(store, sorted(frame["session_id"].astype(str).unique()))
    origin = {k: info["where"][k] for k in values}
    for key, value in (overrides or {}).items():
        if value is not None:
            values[key] = float(value)
            origin[key] = "command line"
    notes = []
    stand_in = measured_maxima(frame)
    for key in DRIVE_KEYS:
        if key not in values:
            values[key] = stand_in[key]
            origin[key] = "measured maximum"
            notes.append(f"no {key} in the campaign (drive.toml or session.toml): the measured "
                         f"maximum {stand_in[key]:.6g} stands in for it")
    by_origin: dict[str, list[str]] = {}
    for key in (*DRIVE_KEYS, *ENVELOPE_KEYS):
        if key in values:
            by_origin.setdefault(origin[key], []).append(key)
    parts = [f"{', '.join(keys)} from {where}" for where, keys in by_origin.items()]
    source = "; ".join(parts + info["notes"])
    try:
        rating = Drive.rating(**{k: values[k] for k in DRIVE_KEYS},
                              **{k: values[k] for k in ENVELOPE_KEYS if k in values},
                              source=source)
    except ValueError as exc:
        raise InputError(None, f"drive rating: {exc}") from None
    return rating, notes
