"""The candidate drives of a sizing: the reference drive scaled in torque, and drive files.

The reference drive is the system's drive in force
(:func:`optimize.system.drive_in_force.drive_in_force`) with the overrides of
``bench size`` (:func:`reference_rating`); the candidates are it scaled by the
torque-rating law of :mod:`energy.sizing`, plus one per power-model file.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from kernel.drive import Drive
from kernel.errors import InputError

#: no override: the reference rating is the system's drive in force
NO_OVERRIDES = Drive()


#: the keys of the reference rating ``bench size`` overrides (``--continuous-torque-nm``,
#: ``--max-speed-rpm``, ``--max-torque-nm``), in the order they are checked
OVERRIDE_KEYS = ("continuous_torque_nm", "max_speed_rpm", "max_torque_nm")


def reference_rating(rating: Any, overrides: Drive = NO_OVERRIDES) -> tuple[Any, list[str]]:
    """The reference drive's rating (x1): the system's drive in force, the limits
    ``bench optimize``'s constrained kinds fly, with the given overrides
    ``overrides`` (a :class:`kernel.drive.Drive` stating keys of :data:`OVERRIDE_KEYS` only:
    ``--continuous-torque-nm``, ``--max-speed-rpm``, ``--max-torque-nm``).

    The peak torque is the system's ``max_torque_nm``: a short-time torque above it is
    flown only where the system file (or ``--max-torque-nm``) states it as the drive's
    limit. A continuous torque the system does not state, a stated ``overload`` that no
    stage flies, and an override that departs from the system's limits are said.
    """
    notes = []
    stated = sorted(f.name for f in dataclasses.fields(overrides)
                    if getattr(overrides, f.name) is not None and f.name not in OVERRIDE_KEYS)
    if stated:
        raise InputError(None, f"rating override {stated[0]}: not one bench size overrides",
                         expected=", ".join(OVERRIDE_KEYS))
    continuous_torque_nm, max_speed_rpm, max_torque_nm = (getattr(overrides, k)
                                                          for k in OVERRIDE_KEYS)
    for key in OVERRIDE_KEYS:
        v = getattr(overrides, key)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(None, f"option --{key.replace('_', '-')} {v}",
                             expected="a value > 0")
    peak = max_torque_nm or rating.max_torque_nm
    continuous = continuous_torque_nm or rating.continuous_torque_nm
    if continuous is None:
        continuous = peak
        notes.append(f"the system's [drive] states no continuous_torque_nm: its torque limit "
                     f"{peak:g} N m is taken as the continuous rating")
    if rating.overload is not None and rating.overload * continuous > peak:
        notes.append(f"the system's [drive] states overload {rating.overload:g} (a short-time "
                     f"{rating.overload * continuous:g} N m): not flown; the drive's torque "
                     f"limit is max_torque_nm {peak:g} N m, as in bench optimize (state a "
                     "short-time torque as max_torque_nm to fly it)")
    departs = [f"{opt} {v:g}" for opt, v, own in (
        ("--max-torque-nm", max_torque_nm, rating.max_torque_nm),
        ("--max-speed-rpm", max_speed_rpm, rating.max_speed_rpm),
        ("--continuous-torque-nm", continuous_torque_nm, rating.continuous_torque_nm))
        if v is not None and v != own]
    if departs:
        notes.append(f"x1 is not the drive bench optimize flies: {', '.join(departs)} in place "
                     "of the system's [drive]")
    if continuous > peak:
        notes.append(f"continuous torque {continuous:g} N m above the torque limit {peak:g} "
                     "N m: the continuous rating never binds")
    return dataclasses.replace(rating, continuous_torque_nm=continuous, max_torque_nm=peak,
                               max_speed_rpm=max_speed_rpm or rating.max_speed_rpm,
                               overload=None), notes


def build_candidates(drive: Any, scales: tuple[float, ...], models: tuple = (),
                     overrides: Drive = NO_OVERRIDES) -> tuple[list, list[str]]:
    """The candidate drives of the reference drive in force (``drive``, a
    :class:`kernel.drive.Drive` with its losses,
    :func:`optimize.system.drive_in_force.drive_in_force`) scaled by ``scales``, plus one per
    power-model file of ``models`` (the reference's rating with ``overrides``,
    :func:`reference_rating`); and notes on what was assumed."""
    from energy.sizing import Candidate, scaled_candidates
    from fitting.model_file import load_power_model
    rating, notes = reference_rating(drive.rating_part(), overrides)
    candidates = scaled_candidates(rating.with_losses(drive.power_model), tuple(scales))
    names = _model_names(tuple(models), {c.name for c in candidates})
    for p in models:
        m = load_power_model(p)
        own = m.drive or Drive()
        peak = own.max_torque_nm or rating.max_torque_nm
        cont = own.continuous_torque_nm
        if cont is None:
            cont = peak * rating.continuous_torque_nm / rating.max_torque_nm
            notes.append(f"{p}: its drive states no continuous_torque_nm: {cont:g} N m, the "
                         "reference drive's continuous share of its torque limit")
        flown = Drive.rating(m.nominal_power_w,
                             own.max_speed_rpm or rating.max_speed_rpm,
                             peak, source=str(p), continuous_torque_nm=cont,
                             max_p_elec_w=rating.max_p_elec_w)
        candidates.append(Candidate(names[Path(p)], flown.with_losses(m), path=Path(p)))
    return candidates, notes


def _model_names(models: tuple, taken: set[str]) -> dict[Path, str]:
    """Each ``--models`` file's candidate name: its file name without ``.json``, or, where
    two files (or a scale's ``x<s>``) would share it, the path as given."""
    paths = [Path(p) for p in models]
    seen: set[Path] = set()
    for p in paths:
        if p.resolve() in seen:
            raise InputError(p, "given twice to --models", column="--models",
                             expected="each power-model file once")
        seen.add(p.resolve())
    stems = [p.stem for p in paths]
    return {p: (p.stem if stems.count(p.stem) == 1 and p.stem not in taken else str(p))
            for p in paths}


