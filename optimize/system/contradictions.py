"""Bounds of different parts that cannot hold together, refused before any solve.

Each part of a system may be plausible on its own (:mod:`optimize.system.plausibility`)
and still contradict another: a ground clearance above what the longest tether reaches,
a tension floor the drive cannot pull on its drum, a base
speed or envelope table that leaves the drive far less power than its nominal power, a
table so steep that the smooth bound the OCP enforces in its place falls to nothing, a
thermal model by which the drive's continuous rating would heat its winding to thousands
of degrees. The OCP would then spend minutes in IPOPT and end infeasible, on a numerical
assertion or at its iteration limit, without naming either key. :func:`check_contradictions`
runs once the drive in force and the OCP's limits are known (``bench optimize`` and every
candidate of ``bench size``) and raises :class:`~kernel.errors.InputError` naming both
keys, the values and what would hold together.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from kernel.errors import InputError
from kernel.sections import bound_keys, bound_values
from kernel.units import RPM_PER_RAD_S

#: the envelope must leave the drive at least this share of its nominal power (a drive
#: gives its nominal power at its base speed: ``T_max w_base >= P_nom``, the peak torque
#: at least the rated one); below half of it the keys contradict each other
MIN_ENVELOPE_POWER_SHARE = 0.5
#: the smooth bound enforced in place of an envelope table must keep at least this share
#: of the table's torque at every speed up to the speed limit
MIN_SMOOTH_ENVELOPE_SHARE = 0.5
#: the steady winding rise at the continuous rating may be at most this many times the
#: rise to the winding limit (a drive's continuous rating is where its winding reaches
#: about its limit; ten times that is no model of that drive)
MAX_THERMAL_RISE_RATIO = 10.0
#: speeds at which an envelope table is checked, over its speed range
_SAMPLES = 401


def _where(source: str | None) -> str:
    return "" if not source else f"{source}: "


def check_tension_floor(system: Any, constrained: bool, source: str | None = None) -> None:
    """Refuse a tension floor above what the drive in force (``system.drive``) can pull on
    its drum in the kinds that fly its limits (``constrained``), or above what its
    continuous (RMS) torque carries on average: the torque at the drum over the cycle is
    at least the floor's at every instant, so its peak and its RMS are too."""
    floor, drive = bound_values(system.bounds)["tension_min"], system.drive
    torque_key = bound_keys(drive)["torque_limit"]
    if not constrained or floor is None or floor <= 0 or getattr(drive, torque_key) is None:
        return
    w, key_of_floor = system.winch, bound_keys(system.bounds)["tension_min"]
    torque_nm = floor * w.drum_radius_m / w.gear_ratio
    for key, limit, what in ((torque_key, getattr(drive, torque_key), "torque limit"),
                             ("continuous_torque_nm", drive.rms_torque_limit_nm,
                              "continuous (RMS) torque rating")):
        if limit is None or torque_nm <= limit:
            continue
        pull_n = drive.held_tension_n(w.drum_radius_m, w.gear_ratio, limit)
        raise InputError(system.path, f"{_where(source)}[bounds] {key_of_floor}: the tension "
                         f"floor {floor:g} N needs {torque_nm:.4g} N m on the "
                         f"{w.drum_radius_m:g} m drum (gear ratio {w.gear_ratio:g}), above "
                         f"the drive's {what} [drive] {key} {limit:g} N m, which pulls at "
                         f"most {pull_n:.4g} N: the kinds with drive limits (*-lim) hold no "
                         "cycle", expected=f"{key_of_floor} below {pull_n:.4g} N, or a "
                         f"{key} of at least {torque_nm:.4g} N m")


def check_clearance(system: Any) -> None:
    """Refuse a ground clearance the kite cannot reach on the longest tether: its altitude
    is at most the winch's height plus the tether's length (straight up), so a clearance
    at or above that leaves no cycle in any kind."""
    b, w = system.bounds, system.wind
    top_m = w.winch_height_m + b.tether_length_max_m
    if b.min_ground_clearance_m < top_m:
        return
    raise InputError(system.path, f"[bounds] min_ground_clearance_m: {b.min_ground_clearance_m:g} "
                     f"m, while the kite flies at most {top_m:g} m high ([wind] "
                     f"winch_height_m {w.winch_height_m:g} m plus [bounds] tether_length_max_m "
                     f"{b.tether_length_max_m:g} m, the tether straight up): no kind holds a "
                     "cycle", expected=f"min_ground_clearance_m well below {top_m:g} m, or a "
                     "longer tether_length_max_m")


def envelope_power_w(drive: Any) -> float | None:
    """The largest power [W] the drive's torque-speed envelope leaves it up to its speed
    limit (``T(n) w``), None when it states no envelope."""
    if drive.base_speed_rpm is not None:
        top = drive.max_speed_rpm if drive.max_speed_rpm is not None else np.inf
        return drive.constant_power_w(top)
    if drive.envelope_speed_rpm is None:
        return None
    speed, torque = _table_samples(drive)
    return float(np.max(torque * speed / RPM_PER_RAD_S))


def _table_samples(drive: Any) -> tuple[np.ndarray, np.ndarray]:
    """Speeds [rpm] up to the speed limit (else the table's last speed) and the table's
    largest torque there [N m] (capped by the torque limit)."""
    speeds = np.asarray(drive.envelope_speed_rpm, dtype=float)
    top = drive.max_speed_rpm if drive.max_speed_rpm is not None else float(speeds[-1])
    speed = np.unique(np.concatenate([np.linspace(0.0, top, _SAMPLES), speeds[speeds <= top]]))
    return speed, drive.largest_torque_nm(speed)


def check_envelope(drive: Any, path: str | Path | None, source: str | None = None) -> None:
    """Refuse an envelope that leaves the drive less than half its nominal power, and a
    table whose smooth bound (the one the OCP enforces) keeps less than half the table's
    torque somewhere up to the speed limit (a table too steep for its rounding)."""
    from optimize.model.envelope import EnvelopeTable

    power = envelope_power_w(drive)
    nominal = drive.nominal_power_w
    if power is not None and nominal and power < MIN_ENVELOPE_POWER_SHARE * nominal:
        keys = ("base_speed_rpm" if drive.base_speed_rpm is not None
                else "envelope_speed_rpm, envelope_torque_nm")
        raise InputError(path, f"{_where(source)}[drive] {keys}: the torque-speed envelope "
                         f"leaves the drive at most {power:.4g} W up to its speed limit, "
                         f"less than {MIN_ENVELOPE_POWER_SHARE:.0%} of its nominal_power_w "
                         f"{nominal:g} W: no envelope of that drive",
                         expected=f"a base speed (or table) at which "
                                  f"{bound_keys(drive)['torque_limit']} times the speed is "
                                  "about the nominal power (base_speed_rpm about "
                                  f"{drive.corner_speed_rpm():.4g} rpm)")
    if drive.envelope_speed_rpm is None:
        return
    speed, torque = _table_samples(drive)
    smooth = EnvelopeTable(tuple(drive.envelope_speed_rpm),
                           tuple(drive.envelope_torque_nm)).smooth_values_nm(speed)
    share = smooth / torque
    i = int(np.argmin(share))
    if share[i] < MIN_SMOOTH_ENVELOPE_SHARE:
        raise InputError(path, f"{_where(source)}[drive] envelope_speed_rpm, "
                         f"envelope_torque_nm: the table is too steep for the smooth bound "
                         f"the OCP enforces in its place: at {speed[i]:.4g} rpm that bound is "
                         f"{smooth[i]:.4g} N m against the table's {torque[i]:.4g} N m",
                         expected="a table whose torque falls over a speed range of more "
                                  "than 1 % of its last speed at each step (more points, or "
                                  "a less abrupt fall)")


def check_thermal(drive_model: Any, drive: Any, model_path: str | Path | None,
                  source: str | None = None) -> None:
    """Refuse a thermal model by which the drive's continuous rating (its RMS torque
    rating, else its torque limit, at the speed of its nominal power) heats the winding
    more than :data:`MAX_THERMAL_RISE_RATIO` times as far as its limit allows."""
    from optimize.model.thermal import WindingThermal

    limit = drive.max_winding_temperature_c
    if limit is None or getattr(drive_model, "thermal", None) is None:
        return
    try:
        thermal = WindingThermal.of(drive_model, limit, drive.ambient_temperature_c)
    except (ValueError, KeyError, TypeError):
        return  # said with its key where the thermal line is made (a limit below ambient)
    torque = drive.thermal_torque_nm()
    if not torque or not drive.nominal_power_w:
        return
    speed = drive.corner_speed_rpm(torque)
    if drive.max_speed_rpm is not None:
        speed = min(speed, drive.max_speed_rpm)
    loss_w = float(drive_model.p_elec_w(np.array([speed]), np.array([torque]))[0]
                   - speed / RPM_PER_RAD_S * torque)
    allowed_k = limit - thermal.ambient_c
    rise_k = thermal.r_th_k_per_w * loss_w
    if loss_w <= 0 or rise_k <= MAX_THERMAL_RISE_RATIO * allowed_k:
        return
    raise InputError(model_path, f"{_where(source)}field 'thermal' (r_th "
                     f"{thermal.r_th_k_per_w:.4g} K/W): the drive's continuous rating "
                     f"({torque:g} N m at {speed:.4g} rpm, "
                     f"{loss_w:.4g} W of losses) would heat the winding {rise_k:.4g} K above "
                     f"the {thermal.ambient_c:g} degC ambient, {rise_k / allowed_k:.3g} times "
                     f"the {allowed_k:g} K to the winding limit max_winding_temperature_c "
                     f"{limit:g} degC: that thermal model is not of this drive",
                     expected=f"a thermal resistance of the order of {allowed_k / loss_w:.3g} "
                              "K/W (the winding near its limit at the continuous rating): "
                              "the thermal block bench fit fits with this drive's losses")


def check_contradictions(system: Any, drive_model: Any, kinds: tuple[str, ...],
                         model_path: str | Path | None = None,
                         source: str | None = None) -> None:
    """Refuse bounds of different parts that cannot hold together (module docstring).

    Parameters
    ----------
    system : optimize.system.system.System
        The kite, tether, winch and bounds, with the drive in force
        (:meth:`optimize.system.system.System.in_force`).
    drive_model : fitting.power_model.PowerModel
        The drive's losses (and thermal model) in force.
    kinds : tuple of str
        The scenario kinds solved (the drive's limits apply in the ``*-lim`` ones).
    model_path : path, optional
        Where the power model was read (named by a thermal contradiction).
    source : str, optional
        What the drive is, said first (``"candidate x0.5"``).

    Raises
    ------
    InputError
        Naming the file, both keys and what would hold together.
    """
    from optimize.kinds import KINDS

    constrained = any(KINDS[k].drive_limits for k in kinds)
    check_clearance(system)
    check_tension_floor(system, constrained, source)
    if constrained:
        check_envelope(system.drive, system.path, source)
        check_thermal(drive_model, system.drive, model_path, source)


def check_drive(system: Any, drive_model: Any, model_path: str | Path | None,
                kinds: tuple[str, ...], source: str | None = None,
                rating_source: str | None = None) -> None:
    """Every check of a drive in a system before any solve, as ``bench optimize`` makes
    them and ``bench size`` for each candidate: a physically possible power model within
    the drive's limits (:func:`fitting.model_check.check_physics`), a torque limit that
    holds the kite's weight on the drum
    (:func:`optimize.system.plausibility.check_drive_holds_kite`) and no contradiction
    between the parts (:func:`check_contradictions`).

    ``source`` says what the drive is in the messages (``"candidate x0.5"``),
    ``rating_source`` where its torque limit comes from; the other parameters are those
    of :func:`check_contradictions`.
    """
    from fitting.model_check import check_physics
    from optimize.system.plausibility import check_drive_holds_kite

    try:
        drive = system.drive
        check_physics(drive_model, model_path, limits=drive.box())
        check_drive_holds_kite(system, drive, rating_source or "the drive in force")
        check_contradictions(system, drive_model, kinds, model_path)
    except InputError as exc:
        if not source:
            raise
        raise InputError(exc.path, f"{source}: {exc.problem}", line=exc.line,
                         column=exc.column, expected=exc.expected) from None
