"""The candidate drives of a sizing: the reference drive scaled in torque, and drive files.

The reference drive is the system's drive in force
(:func:`optimize.system.drive_in_force.drive_in_force`) with the overrides of
``bench size`` (:func:`reference_rating`); the candidates are it scaled by the
torque-rating law of :mod:`energy.sizing`, plus one per power-model file.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from kernel.errors import InputError


def _drive_value(path: Path, key: str) -> float | None:
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
        return None
    drive = data.get("drive") if isinstance(data, dict) else None
    value = drive.get(key) if isinstance(drive, dict) else None
    return float(value) if isinstance(value, int | float) and value > 0 else None


def reference_rating(rating: Any, rated_torque_nm: float | None = None,
                     max_speed_rpm: float | None = None,
                     overload: float | None = None) -> tuple[Any, list[str]]:
    """The reference drive's rating: the system's drive in force with the given
    overrides (``--rated-torque-nm``, ``--max-speed-rpm``, ``--overload``); a continuous
    torque or an overload the system does not state is said."""
    notes = []
    for name, v in (("--rated-torque-nm", rated_torque_nm),
                    ("--max-speed-rpm", max_speed_rpm), ("--overload", overload)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(None, f"{name} {v}", expected="a value > 0")
    if overload is not None and overload < 1:
        raise InputError(None, f"--overload {overload}", expected="a factor >= 1")
    continuous = rated_torque_nm or rating.continuous_torque_nm
    if continuous is None:
        continuous = rating.max_torque_nm
        notes.append(f"the system's [drive] states no continuous_torque_nm: its torque limit "
                     f"{continuous:g} N m is taken as the continuous rating")
    overload = overload or rating.overload
    peak = overload * continuous if overload is not None else max(rating.max_torque_nm,
                                                                   continuous)
    if overload is None:
        notes.append(f"the system's [drive] states no overload: peak torque {peak:g} N m")
    return dataclasses.replace(rating, continuous_torque_nm=continuous, max_torque_nm=peak,
                               max_speed_rpm=max_speed_rpm or rating.max_speed_rpm,
                               overload=peak / continuous), notes


def build_candidates(drive: Any, scales: tuple[float, ...], models: tuple = (),
                     rated_torque_nm: float | None = None, max_speed_rpm: float | None = None,
                     overload: float | None = None) -> tuple[list, list[str]]:
    """The candidate drives of the reference drive in force (``drive``,
    :func:`optimize.system.drive_in_force.drive_in_force`) scaled by ``scales``, plus one per
    power-model file of ``models``; and notes on what was assumed."""
    from energy.sizing import Candidate, scaled_candidates
    from fitting.model_file import load_power_model
    from kernel.drive_rating import DriveRating

    rating, notes = reference_rating(drive.rating, rated_torque_nm, max_speed_rpm, overload)
    candidates = scaled_candidates(drive.model, rating, tuple(scales))
    for p in models:
        m = load_power_model(p)
        cont = _drive_value(p, "max_torque_nm") or rating.continuous_torque_nm
        own = DriveRating(_drive_value(p, "nominal_power_w") or m.nominal_power_w,
                          _drive_value(p, "max_speed_rpm") or rating.max_speed_rpm,
                          rating.overload * cont, source=str(p), continuous_torque_nm=cont,
                          overload=rating.overload, max_p_elec_w=rating.max_p_elec_w)
        candidates.append(Candidate(Path(p).stem, m, own))
    return candidates, notes


