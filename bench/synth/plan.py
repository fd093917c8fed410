"""The campaign design: which sessions, in which formats, visiting which operating points.

A session visits speed levels in a shuffled order and, at each speed, steps the
brake (motor mode) or the prime mover's torque (generator mode) through a set of
torque levels, as a bench operator does. ``scale`` repeats the sweep ``scale``
times with fresh jitter and order, so a campaign at ``--scale N`` holds N times the
points and N times the logging time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kernel.drive import Drive
from kernel.units import RPM_PER_RAD_S

MOTOR_SPEED_RPM = (50.0, 1500.0)
GENERATOR_SPEED_RPM = (30.0, 3000.0)  # magnitudes; drum speed is negative
TORQUE_MIN_NM = 1.0  # the lowest brake setting the bench holds steadily
TORQUE_MAX_NM = 78.0
GENERATOR_POWER_MAX_W = 10_000.0

#: The campaign's drive (written as drive.toml): the paper's drive and its constraints.
DRIVE = Drive.rating(
    nominal_power_w=8200.0,
    max_speed_rpm=MOTOR_SPEED_RPM[1],
    max_torque_nm=TORQUE_MAX_NM,
    source="Stuyts et al. 2015, section III-B: 8.2 kW Siemens "
           "Simotics PMSM with a 1:3 gearbox; the nominal motor torque and the gearbox's "
           "maximum speed, 78 N m and 1500 rpm on the drum side, are the drive constraints",
)


@dataclass(frozen=True)
class SessionSpec:
    """One bench session: what it measures, how it logs, and its instruments' clocks.

    Parameters
    ----------
    session_id : str
        Folder name and ``session.toml`` id.
    kind : str
        ``"timeseries"`` or ``"operating_points"``.
    mode : str
        ``"motor"`` or ``"generator"``.
    n_speeds : int
        Speed levels per sweep.
    n_torques : int
        Torque levels per speed.
    grid_phase : float
        Offset of the speed grid as a fraction of one grid step [-], so sessions of
        one mode interleave.
    daq_format : str
        ``"csv_en"``, ``"csv_de"`` or ``"tdms"``.
    analyzer_style : str
        ``"en_kw"``, ``"en_w"`` or ``"de_w"`` (German locale, units row).
    measured_side : str
        ``"drum"`` or ``"motor"`` (speed x gear ratio, torque / gear ratio logged).
    speed_sign : int
        Drum speed = logged speed x speed_sign (after the gear conversion).
    torque_sign : int
        Drum torque = logged torque x torque_sign.
    operator : str
        Who ran the bench.
    date : str
        ISO date of the session.
    daq_start_time : str
        Wall time ``HH:MM:SS.mmm`` of the DAQ clock's time 0.
    analyzer_delay_s : float
        True time after the DAQ start at which the analyzer takes its time 0 [s].
    analyzer_clock_error_s : float
        Error of the analyzer's wall clock against the DAQ's (header offset) [s].
    analyzer_drift_ppm : float
        Analyzer clock rate error relative to the DAQ clock [ppm].
    theta_start_c : float
        Winding temperature at the start of the session [degC].
    ambient_c : float
        Bench-room temperature [degC].
    notes : str
        Free text for ``session.toml``.
    """

    session_id: str
    kind: str
    mode: str
    n_speeds: int
    n_torques: int
    grid_phase: float
    daq_format: str
    analyzer_style: str
    measured_side: str
    speed_sign: int
    torque_sign: int
    operator: str
    date: str
    daq_start_time: str
    analyzer_delay_s: float
    analyzer_clock_error_s: float
    analyzer_drift_ppm: float
    theta_start_c: float
    ambient_c: float
    notes: str


GEAR_RATIO = 3.0  # motor-shaft speed / drum-shaft speed

#: the shipped campaign (scale 1: 560 motor points, 664 generator points)
CAMPAIGN: tuple[SessionSpec, ...] = (
    SessionSpec(
        "motor_01", "timeseries", "motor", 20, 14, 0.0, "csv_en", "en_kw", "drum", 1, 1,
        "J. Doe", "2013-04-17", "09:12:03.250", 0.85, 1.42, 37.0, 21.5, 21.5,
        "particle brake below 300 rpm, eddy-current brake above; torque flange on the drum side",
    ),
    SessionSpec(
        "motor_02", "timeseries", "motor", 20, 14, 0.5, "csv_de", "de_w", "motor", 1, 1,
        "K. M\u00fcller", "2013-04-18", "13:40:11.500", 1.30, -2.35, 64.0, 46.0, 23.0,
        "Messung auf der Motorseite des Getriebes (i = 3); warm start after a previous run",
    ),
    SessionSpec(
        "generator_01", "timeseries", "generator", 20, 13, 0.0, "tdms", "en_w", "drum", -1, 1,
        "J. Doe", "2013-04-22", "10:05:47.000", 0.60, 0.78, 22.0, 22.0, 22.0,
        "second drive as prime mover; speed encoder logs the magnitude (speed_sign = -1)",
    ),
    SessionSpec(
        "generator_02", "timeseries", "generator", 20, 13, 0.5, "csv_en", "en_kw", "drum", 1, 1,
        "A. Smith", "2013-04-23", "08:55:30.125", 1.10, 2.61, 71.0, 24.0, 20.5,
        "second drive as prime mover; analog torque measurement",
    ),
    SessionSpec(
        "generator_table_03", "operating_points", "generator", 12, 12, 0.25, "", "", "drum", 1, 1,
        "A. Smith", "2013-04-24", "09:30:00.000", 0.0, 0.0, 0.0, 35.0, 21.0,
        "exported by the bench software as averaged operating points (foreign column names)",
    ),
)


def torque_levels_nm(mode: str, speed_rpm: float, n_torques: int) -> np.ndarray:
    """Nominal torque levels at one speed [N m], from TORQUE_MIN_NM to the mode's limit.

    In generator mode the limit is ``min(78 N m, 10 kW / |omega|)``.
    """
    top = TORQUE_MAX_NM
    if mode == "generator":
        top = min(top, GENERATOR_POWER_MAX_W / (abs(speed_rpm) / RPM_PER_RAD_S))
    return np.linspace(TORQUE_MIN_NM, top, n_torques)


def operating_points(spec: SessionSpec, scale: int, rng: np.random.Generator):
    """Setpoints of one session in visiting order, drum frame.

    Parameters
    ----------
    spec : SessionSpec
        The session.
    scale : int
        Number of sweeps.
    rng : numpy.random.Generator
        Source of the jitter and the speed order.

    Returns
    -------
    speed_rpm, torque_nm : numpy.ndarray
        Setpoints [rpm] (negative in generator mode) and [N m].
    """
    lo, hi = MOTOR_SPEED_RPM if spec.mode == "motor" else GENERATOR_SPEED_RPM
    step = (hi - lo) / (spec.n_speeds - 1)
    speeds_all, torques_all = [], []
    for _ in range(scale):
        grid = lo + step * (np.arange(spec.n_speeds) + spec.grid_phase)
        grid = grid + rng.uniform(-0.15, 0.15, spec.n_speeds) * step
        grid = np.clip(grid, lo, hi)
        grid = np.round(grid[rng.permutation(spec.n_speeds)], 0)
        for n in grid:
            levels = torque_levels_nm(spec.mode, n, spec.n_torques)
            dt = (levels[1] - levels[0]) * rng.uniform(-0.1, 0.1, spec.n_torques)
            dt[0] = dt[-1] = 0.0  # keep the end points exactly on the range limits
            # round to the controller's 0.01 N m, never above the mode's limit
            t = np.minimum(np.round(levels + dt, 2), np.floor(levels[-1] * 100.0) / 100.0)
            speeds_all.append(np.full(spec.n_torques, n))
            torques_all.append(t)
    speed = np.concatenate(speeds_all)
    if spec.mode == "generator":
        speed = -speed
    return speed, np.concatenate(torques_all)
