"""Small synthetic bench sessions with a known truth, written as schemas.md section 1 says.

Independent of ``bench synth``: the ingest tests must know the exact setpoints,
clock offset and drift that went into each file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

# paper Table I (docs/paper_figures.md §1): P_elec = a0 + a1 rpm^2 + a2 T^2 + a3 rpm T
A0, A1, A2, A3 = 293.5816373499238, 0.0003931623408, 0.0665919381751, 0.1078628659825
DAQ_START = datetime(2013, 4, 17, 9, 12, 3, 250000)


def paper_p_elec(speed_rpm, torque_nm):
    """Paper Table I quadratic [W] (speed [rpm], torque [N m], drum frame)."""
    return A0 + A1 * speed_rpm**2 + A2 * torque_nm**2 + A3 * speed_rpm * torque_nm


@dataclass
class Truth:
    """What went into a synthetic session."""

    setpoints: list[tuple[float, float]]  # (speed_rpm, torque_nm), drum frame
    step_times_s: list[float]  # DAQ clock
    offset_s: float  # DAQ time at analyzer time 0
    drift_ppm: float
    prior_offset_s: float  # what the headers say
    p_elec_w: list[float] = field(default_factory=list)


def _response(t, steps, levels, tau):
    """First-order response to a staircase of setpoints."""
    out = np.full(t.shape, levels[0], dtype=float)
    for k in range(1, len(levels)):
        m = t >= steps[k]
        out[m] = levels[k] + (levels[k - 1] - levels[k]) * 0 + (
            out[m] - levels[k]) * np.exp(-(t[m] - steps[k]) / tau)
    return out


def make_timeseries_session(
    root: Path,
    sid: str = "motor_01",
    mode: str = "motor",
    setpoints: list[tuple[float, float]] | None = None,
    hold_s: float = 6.0,
    daq_hz: float = 100.0,
    analyzer_hz: float = 10.0,
    offset_err_s: float = 1.3,
    drift_ppm: float = 40.0,
    locale: str = "en",
    daq_format: str = "csv",
    seed: int = 1,
    torque_sign_logged: int = 1,
    markers: bool = True,
    power_unit: str = "kW",
    hunting_hold: int | None = None,
) -> Truth:
    """Write ``root/sid/{session.toml, daq.csv|daq.tdms, analyzer.csv}``; return the truth."""
    rng = np.random.default_rng(seed)
    if setpoints is None:
        sgn = 1.0 if mode == "motor" else -1.0
        setpoints = [(sgn * s, q) for s in (300.0, 900.0) for q in (10.0, 40.0, 70.0)]
    n = len(setpoints)
    duration = (n + 0.5) * hold_s
    steps = [0.0] + [0.5 * hold_s + k * hold_s for k in range(1, n)]
    t = np.arange(0.0, duration, 1.0 / daq_hz) + 0.004
    speed = _response(t, steps, [s for s, _ in setpoints], 0.25)
    torque = _response(t, steps, [q for _, q in setpoints], 0.15)
    speed_log = speed + rng.normal(0, 1.0, t.size)
    if hunting_hold is not None:  # the speed loop hunts at 1.5 Hz, +-8 rpm, in this hold
        h = (t >= steps[hunting_hold]) & (t < steps[hunting_hold] + hold_s)
        speed_log[h] += 8.0 * np.sin(2 * np.pi * 1.5 * t[h])
    torque_log = (torque + rng.normal(0, 0.15, t.size)) * torque_sign_logged

    prior = 0.85
    offset = prior + offset_err_s
    ta = np.arange(0.0, duration - offset - 0.5, 1.0 / analyzer_hz)
    td = offset + (1 + drift_ppm * 1e-6) * ta
    # each record is the mean power over the interval that ends at its time stamp
    sub = td[:, None] - (np.arange(10) + 0.5)[None, :] / 10 / analyzer_hz
    p_true = paper_p_elec(np.interp(sub, t, speed), np.interp(sub, t, torque)).mean(axis=1)
    p = p_true + rng.normal(0, 3.0, ta.size)

    folder = root / sid
    folder.mkdir(parents=True)
    daq_file = "daq.tdms" if daq_format == "tdms" else "daq.csv"
    if daq_format == "tdms":
        from nptdms import ChannelObject, TdmsWriter

        with TdmsWriter(folder / daq_file) as w:
            w.write_segment([
                ChannelObject("Measurement", "Time", t, properties={"unit_string": "s"}),
                ChannelObject("Measurement", "Speed", speed_log,
                              properties={"unit_string": "1/min"}),
                ChannelObject("Measurement", "Torque", torque_log,
                              properties={"unit_string": "N m"}),
            ])
    else:
        cells = np.column_stack([t, speed_log, torque_log]).astype(object)
        if markers:
            for row, col, text in ((40, 1, "9.91E+37"), (333, 2, "NAN"), (1000, 2, "---")):
                cells[row, col] = text
        _write_daq_csv(folder / daq_file, cells, locale)
    a_start = DAQ_START + timedelta(seconds=prior)
    scale = 1e-3 if power_unit == "kW" else 1.0
    rows = [[k + 1, f"{ta[k]:.3f}", "400.1", "2.3", f"{p[k] * scale:.6f}", "0.98"]
            for k in range(ta.size)]
    if markers:
        rows[25][4] = "9.91E+37"
    lines = [
        "Yokogawa,WT1800,Power Analyzer", "Model,WT1800", "Serial,91M123456",
        f"Start Date,{a_start:%Y/%m/%d}", f"Start Time,{a_start:%H:%M:%S}.{a_start:%f}"[:-3],
        "Sample Interval,100ms", "Wiring,3P4W", "",
        f"Store No.,Time [s],Urms_sigma [V],Irms_sigma [A],P_sigma [{power_unit}],PF_sigma []",
    ] + [",".join(map(str, r)) for r in rows]
    (folder / "analyzer.csv").write_text("\n".join(lines) + "\n")
    daq_extra = 'tdms_group = "Measurement"\n' if daq_format == "tdms" else ""
    (folder / "session.toml").write_text(f'''session_id = "{sid}"
kind = "timeseries"
mode = "{mode}"
operator = "J. Doe"
date = "2013-04-17"
gear_ratio = 3.0
measured_side = "drum"
speed_sign = 1
torque_sign = 1
notes = "fixture"

[daq]
file = "{daq_file}"
format = "{daq_format}"
start = "{DAQ_START.isoformat(timespec='milliseconds')}"
{daq_extra}
[analyzer]
file = "analyzer.csv"
format = "vendor_csv"

[sensors]
torque_range_nm = 100.0
speed_range_rpm = 3000.0
power_range_w = 15000.0
''')
    return Truth(setpoints=setpoints, step_times_s=steps, offset_s=offset, drift_ppm=drift_ppm,
                 prior_offset_s=prior, p_elec_w=[paper_p_elec(s, q) for s, q in setpoints])


def _fmt(x) -> str:
    return x if isinstance(x, str) else repr(float(x))


def _write_daq_csv(path: Path, cells, locale: str) -> None:
    if locale == "de":
        head = "Zeit;Drehzahl;Drehmoment\ns;U/min;Nm\n"
        body = "\n".join(";".join(_fmt(c).replace(".", ",") for c in row) for row in cells)
    else:
        head = "Time [s],Speed [1/min],Torque [N m]\n"
        body = "\n".join(",".join(_fmt(c) for c in row) for row in cells)
    path.write_text(head + body + "\n", encoding="utf-8")


def make_points_session(root: Path, sid: str = "table_01", n: int = 30, seed: int = 3,
                        with_mapping: bool = True) -> dict:
    """Write an operating-point table session with foreign column names and a mapping file.

    Speeds are logged on the motor side (3x the drum), power in kW; returns the
    drum-frame truth arrays.
    """
    rng = np.random.default_rng(seed)
    speed = rng.uniform(-1500, 1500, n)
    torque = rng.uniform(1, 78, n)
    p = paper_p_elec(speed, torque)
    folder = root / sid
    folder.mkdir(parents=True)
    rows = ["n_mean;M_mean;P_el;n_std;N"] + [
        f"{3 * s:.4f};{q / 3:.5f};{pe / 1e3:.6f};0,5;500".replace(".", ",")
        for s, q, pe in zip(speed, torque, p, strict=True)
    ]
    (folder / "points.csv").write_text("\n".join(rows) + "\n")
    mapping = '''[columns.speed]
column = "n_mean"
unit = "rpm"
[columns.torque]
column = "M_mean"
unit = "Nm"
[columns.p_elec]
column = "P_el"
unit = "kW"
[columns.speed_std]
column = "n_std"
unit = "rpm"
[columns.n_samples]
column = "N"
unit = ""
'''
    if with_mapping:
        (folder / "mapping.toml").write_text(mapping)
    mapping_line = 'mapping = "mapping.toml"\n' if with_mapping else ""
    (folder / "session.toml").write_text(f'''session_id = "{sid}"
kind = "operating_points"
mode = "motor"
operator = "J. Doe"
date = "2013-04-18"
gear_ratio = 3.0
measured_side = "motor"
speed_sign = 1
torque_sign = 1

[points]
file = "points.csv"
{mapping_line}
[sensors]
torque_range_nm = 100.0
speed_range_rpm = 5000.0  # logged on the motor side: up to 4500 rpm
power_range_w = 15000.0
''')
    return {"speed_rpm": speed, "torque_nm": torque, "p_elec_w": p, "mapping": mapping,
            "p_mech_w": speed * torque * 2 * math.pi / 60}


def store_tree(store: Path) -> dict[str, bytes]:
    """Relative path -> bytes of every file under ``store`` (to prove it did not change).

    The writers' lock file (which holds the last writer's pid) is no store content.
    """
    return {p.relative_to(store).as_posix(): p.read_bytes()
            for p in sorted(store.rglob("*")) if p.is_file() and p.name != ".lock"}
