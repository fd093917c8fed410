"""Single-stream bench logs with a known truth (issue 10 section 2), written into a tmp dir.

- :func:`make_ev_export`: a production-bench style export, one file holding
  everything: hundreds of ``Name [unit]`` columns, a step counter, invalid
  markers, time in ``ms``, speed > 0 always and torque < 0 in generator mode
  (``torque_sign = "signed"``), both quadrants.
- :func:`make_german_logger`: a 1 Hz logger in German locale: tab separated,
  decimal comma, a units row, the time of day only (``hh:mm:ss``), starting
  before midnight, with gaps (one inside a hold, one hiding a setpoint step).

Each returns the drum-frame truth of every hold. Both use the same staircase
and loss model, so the truth is the model's value at each setpoint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

RAD_S_PER_RPM = 2 * math.pi / 60


def losses_w(speed_rpm, torque_nm):
    """Drive losses of the synthetic drive [W] (drum frame, torque >= 0)."""
    return 400.0 + 2e-5 * speed_rpm**2 + 0.03 * torque_nm**2 + 0.004 * np.abs(speed_rpm * torque_nm)


def p_elec_w(speed_rpm, torque_nm):
    """Electrical power [W]: mechanical power plus losses (generating: negative)."""
    return speed_rpm * torque_nm * RAD_S_PER_RPM + losses_w(speed_rpm, torque_nm)


@dataclass(frozen=True)
class StreamTruth:
    """Drum-frame setpoints of the holds and the times they start [s since the first row].

    Parameters
    ----------
    speed_rpm, torque_nm, p_elec_w : array
        Per hold (drum frame) [rpm, N m, W].
    step_s : array
        Start of each hold [s].
    hold_s : float
        Hold length [s].
    split_holds : tuple of int
        Holds a gap cuts in two (each half is a point of its own).
    """

    speed_rpm: np.ndarray
    torque_nm: np.ndarray
    p_elec_w: np.ndarray
    step_s: np.ndarray
    hold_s: float
    split_holds: tuple[int, ...] = ()

    @property
    def quadrant(self) -> np.ndarray:
        return np.where(self.speed_rpm * self.torque_nm > 0, "motor", "generator")


def _staircase(t, step_s, levels, tau_s):
    out = np.full(t.shape, levels[0], dtype=float)
    for k in range(1, len(levels)):
        m = t >= step_s[k]
        out[m] = levels[k] + (out[m] - levels[k]) * np.exp(-(t[m] - step_s[k]) / tau_s)
    return out


def _signals(setpoints, hold_s, rate_hz, rng, noise=(2.0, 0.3, 15.0)):
    speed_set = np.array([s for s, _ in setpoints], float)
    torque_set = np.array([q for _, q in setpoints], float)
    step = np.arange(len(setpoints)) * hold_s
    t = np.arange(0.0, len(setpoints) * hold_s, 1.0 / rate_hz)
    speed = _staircase(t, step, speed_set, 0.3)
    torque = _staircase(t, step, torque_set, 0.2)
    pe = p_elec_w(speed, torque)
    speed = speed + rng.normal(0, noise[0], t.size)
    torque = torque + rng.normal(0, noise[1], t.size)
    pe = pe + rng.normal(0, noise[2], t.size)
    return t, speed, torque, pe, speed_set, torque_set, step


def _session_toml(folder: Path, sid: str, torque_sign: str, ranges: tuple[float, float, float],
                  day: str = "2024-03-05") -> None:
    (folder / "session.toml").write_text(f'''session_id = "{sid}"
kind = "timeseries"
mode = "motor"
operator = "fixture"
date = "{day}"
gear_ratio = 1.0
measured_side = "drum"
speed_sign = 1
torque_sign = {torque_sign}

[log]
file = "log.csv"
format = "csv"

[sensors]
speed_range_rpm = {ranges[0]}
torque_range_nm = {ranges[1]}
power_range_w = {ranges[2]}
''', encoding="utf-8")


def ev_setpoints() -> list[tuple[float, float]]:
    """Drum-frame setpoints: motor then generator points (reel-out: negative speed)."""
    motor = [(s, q) for s in (2000.0, 5000.0) for q in (40.0, 120.0, 200.0)]
    gen = [(-s, q) for s in (3000.0, 6000.0) for q in (60.0, 150.0)]
    return motor + gen


def make_ev_export(root: Path, sid: str = "ev_01", n_extra: int = 300, rate_hz: float = 10.0,
                   hold_s: float = 6.0, seed: int = 7, with_p_mech: bool = True,
                   signed: bool = True) -> StreamTruth:
    """Write ``root/sid/{session.toml, log.csv, mapping.toml}``: an EV bench export.

    The bench logs speed > 0 always and torque < 0 in generator mode (its own
    frame); ``n_extra`` further ``Name [unit]`` columns (temperatures, voltages,
    currents, a step counter) surround the mapped ones; ``9.91E+37`` and
    ``NaN`` markers sit in some cells. ``signed=False`` writes ``torque_sign = 1``
    (to prove that negative drum torque is refused).
    """
    rng = np.random.default_rng(seed)
    sp = ev_setpoints()
    t, speed, torque, pe, s_set, q_set, step = _signals(sp, hold_s, rate_hz, rng,
                                                       noise=(3.0, 0.5, 40.0))
    # the bench's frame: generating = positive speed, negative torque
    gen = speed < 0
    speed_log = np.where(gen, -speed, speed)
    torque_log = np.where(gen, -torque, torque)
    p_mech_log = speed_log * torque_log * RAD_S_PER_RPM
    step_no = np.searchsorted(step, t, side="right")
    names = ["Time [ms]", "Step [-]"]
    cols = [np.round(t * 1e3, 3), step_no.astype(float)]
    kinds = ("Temp_{k} [°C]", "U_phase_{k} [V]", "I_phase_{k} [A]", "Flux_{k} [mWb]")
    for k in range(n_extra):
        names.append(kinds[k % 4].format(k=k))
        cols.append(np.round(rng.normal(50, 5, t.size), 2))
        if k == n_extra // 2:  # the mapped ones sit in the middle, as in a real export
            names += ["n_Shaft [rpm]", "M_Shaft [Nm]", "P_DC_total [kW]", "P_Mech [kW]"]
            cols += [speed_log, torque_log, pe / 1e3, p_mech_log / 1e3]
    cells = np.column_stack(cols).astype(object)
    for r, c in ((15, names.index("M_Shaft [Nm]")), (200, names.index("P_DC_total [kW]")),
                 (333, names.index("n_Shaft [rpm]"))):
        cells[r, c] = "9.91E+37" if r % 2 else "NaN"
    folder = root / sid
    folder.mkdir(parents=True)
    lines = [",".join(names)] + [",".join(c if isinstance(c, str) else f"{c:.6g}" for c in row)
                                 for row in cells]
    (folder / "log.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    mapping = '''[log.columns.time]
column = "Time [ms]"
unit = "ms"
[log.columns.speed]
column = "n_Shaft [rpm]"
unit = "rpm"
[log.columns.torque]
column = "M_Shaft [Nm]"
unit = "Nm"
[log.columns.p_elec]
column = "P_DC_total [kW]"
unit = "kW"
'''
    if with_p_mech:
        mapping += '[log.columns.p_mech]\ncolumn = "P_Mech [kW]"\nunit = "kW"\n'
    (folder / "mapping.toml").write_text(mapping, encoding="utf-8")
    _session_toml(folder, sid, '"signed"' if signed else "1", (12000.0, 400.0, 200000.0))
    return StreamTruth(speed_rpm=s_set, torque_nm=q_set, p_elec_w=p_elec_w(s_set, q_set),
                       step_s=step, hold_s=hold_s)


def german_setpoints() -> list[tuple[float, float]]:
    """Drum-frame setpoints of the 1 Hz logger (both quadrants, a small drive)."""
    return [(300.0, 10.0), (300.0, 40.0), (900.0, 20.0), (900.0, 60.0),
            (-600.0, 30.0), (-600.0, 70.0), (-1200.0, 40.0), (1200.0, 50.0)]


def make_german_logger(root: Path, sid: str = "logger_de", hold_s: float = 40.0,
                       start: datetime = datetime(2024, 3, 5, 23, 57, 30),
                       seed: int = 11, noisy_hold: int | None = None) -> StreamTruth:
    """Write ``root/sid/{session.toml, log.csv}``: a 1 Hz German-locale logger.

    Tab separated, decimal comma, names row ``Uhrzeit  Drehzahl  Drehmoment
    Wirkleistung`` and a units row ``hh:mm:ss  U/min  Nm  kW``; the time of day
    only, from ``start`` (so the log runs through midnight). Two gaps: 12 s
    missing in the middle of hold 2 (it gives two points) and 25 s missing
    around the step from hold 5 to hold 6 (no window may span it). The
    session date is ``start``'s date. ``noisy_hold``: in that hold speed, torque and
    power scatter 12 times as much as elsewhere (a bench less stiff at high speed).
    """
    rng = np.random.default_rng(seed)
    sp = german_setpoints()
    t, speed, torque, pe, s_set, q_set, step = _signals(sp, hold_s, 1.0, rng,
                                                       noise=(1.0, 0.15, 6.0))
    if noisy_hold is not None:
        h = (t >= step[noisy_hold] + 2) & (t < step[noisy_hold] + hold_s)
        speed[h] += rng.normal(0, 12.0, h.sum())
        torque[h] += rng.normal(0, 1.8, h.sum())
        pe[h] += rng.normal(0, 72.0, h.sum())
    keep = np.ones(t.size, bool)
    mid2 = step[2] + hold_s / 2
    keep &= ~((t >= mid2 - 6) & (t < mid2 + 6))
    keep &= ~((t >= step[6] - 10) & (t < step[6] + 15))
    t, speed, torque, pe = t[keep], speed[keep], torque[keep], pe[keep]
    rows = ["Uhrzeit\tDrehzahl\tDrehmoment\tWirkleistung", "hh:mm:ss\tU/min\tNm\tkW"]
    for k in range(t.size):
        wall = start + timedelta(seconds=float(t[k]))
        vals = [f"{speed[k]:.2f}", f"{torque[k]:.3f}", f"{pe[k] / 1e3:.4f}"]
        if k in (50, 170):
            vals[1] = "---"
        rows.append(f"{wall:%H:%M:%S}\t" + "\t".join(v.replace(".", ",") for v in vals))
    folder = root / sid
    folder.mkdir(parents=True)
    (folder / "log.csv").write_text("\n".join(rows) + "\n", encoding="cp1252")
    _session_toml(folder, sid, "1", (3000.0, 100.0, 15000.0), day=f"{start:%Y-%m-%d}")
    return StreamTruth(speed_rpm=s_set, torque_nm=q_set, p_elec_w=p_elec_w(s_set, q_set),
                       step_s=step, hold_s=hold_s, split_holds=(2,))


def cut_analyzer(path: Path, cut: list[tuple[float, float]]) -> None:
    """Remove the rows of a vendor-CSV analyzer record whose time [s] (second column, the
    analyzer's own clock) lies in one of the ``cut`` intervals ``[a, b)``."""
    lines = path.read_text().splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("Store No."))
    keep = [line for line in lines[head + 1:]
            if not any(a <= float(line.split(",")[1]) < b for a, b in cut)]
    path.write_text("\n".join(lines[:head + 1] + keep) + "\n")


def cut_daq(path: Path, cut: list[tuple[float, float]]) -> None:
    """Remove the data rows of a DAQ CSV whose time [s] (first field) lies in one of the
    ``cut`` intervals ``[a, b)`` (the header rows stay)."""
    def inside(line: str) -> bool:
        try:
            t = float(line.split(",")[0])
        except ValueError:
            return False
        return any(a <= t < b for a, b in cut)

    lines = path.read_text().splitlines()
    path.write_text("\n".join(line for line in lines if not inside(line)) + "\n")


def make_counted_log(root: Path, form: str, sid: str = "counted") -> np.ndarray:
    """Write ``root/sid/{session.toml, log.csv, mapping.toml}``: a 4 Hz logger stamping whole
    seconds (``hh:mm:ss``) that drops every 7th row, with a ``Sample`` counter column.

    ``form``: ``stamp_plus_counter`` (the counter numbers the rows within a stamp;
    mapped as ``sample_counter``) or ``counter_alone`` (a running count; the time
    mapped as ``{Sample} / 4`` s). Returns every row's true time [s].
    """
    rng = np.random.default_rng(4)
    t, speed, torque, pe, *_ = _signals(german_setpoints()[:4], 30.0, 4.0, rng,
                                        noise=(1.0, 0.15, 6.0))
    keep = np.arange(t.size) % 7 != 3
    t, speed, torque, pe = t[keep], speed[keep], torque[keep], pe[keep]
    stamp = np.floor(t)
    count = (np.round((t - stamp) * 4) if form == "stamp_plus_counter"
             else np.round(t * 4)).astype(int)
    rows = ["Time [hh:mm:ss],Sample,Speed [rpm],Torque [Nm],Power [W]"]
    rows += [f"10:{int(x) // 60:02d}:{int(x) % 60:02d},{c},{s:.2f},{q:.3f},{p:.1f}"
             for x, c, s, q, p in zip(stamp, count, speed, torque, pe, strict=True)]
    folder = root / sid
    folder.mkdir(parents=True)
    (folder / "log.csv").write_text("\n".join(rows) + "\n")
    _session_toml(folder, sid, "1", (3000.0, 100.0, 15000.0))
    (folder / "mapping.toml").write_text(
        '[log.columns.sample_counter]\ncolumn = "Sample"\nrate_hz = 4\n'
        if form == "stamp_plus_counter" else
        '[log.columns.time]\nexpr = "{Sample} / 4"\nunit = "s"\n')
    return t
