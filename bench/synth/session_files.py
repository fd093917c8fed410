"""The files of one session, as docs/schemas.md section 1 lays them out.

``session.toml``; the DAQ stream (English or German CSV, or NI TDMS); the power
analyzer's vendor CSV export with its header block; or, for operating-point
sessions, ``points.csv`` with foreign column names and its ``mapping.toml``.
Long streams are written chunk by chunk.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
from tqdm import tqdm

from bench.synth import instruments as ins
from bench.synth.loss_model import LossModel
from bench.synth.plan import GEAR_RATIO, SessionSpec
from bench.synth.true_signals import Segments
from bench.synth.winding_sensor import KELVIN_AT_0C, WindingSensor
from bench.synth.writers import CsvStream, TdmsStream, toml_document
from kernel.files import write_text_atomic

DAQ_CHUNK_ROWS = 500_000
ANALYZER_CHUNK_ROWS = 200_000
TDMS_GROUP = "Measurement"

MARKERS_EN = ("9.91E+37", "NAN", "---")
MARKERS_DE = ("NAN", "---", "")  # German exports: no overflow number, but empty cells
MARKERS_TDMS = (np.nan, ins.OVERFLOW)


def _wall(spec: SessionSpec) -> datetime:
    return datetime.fromisoformat(f"{spec.date}T{spec.daq_start_time}")


def _iso_ms(t: datetime) -> str:
    return t.isoformat(timespec="milliseconds")


def session_toml(spec: SessionSpec, files: dict[str, str]) -> str:
    """The session's metadata file; ``files`` maps roles (``daq``, ...) to file names."""
    motor_side = spec.measured_side == "motor"
    top = {
        "session_id": spec.session_id, "kind": spec.kind, "mode": spec.mode,
        "operator": spec.operator, "date": spec.date, "gear_ratio": GEAR_RATIO,
        "measured_side": spec.measured_side, "speed_sign": spec.speed_sign,
        "torque_sign": spec.torque_sign, "notes": spec.notes,
    }
    tables: dict[str, dict] = {}
    if spec.kind == "timeseries":
        daq = {"file": files["daq"], "format": "tdms" if spec.daq_format == "tdms" else "csv",
               "start": _iso_ms(_wall(spec))}
        if spec.daq_format == "tdms":
            daq["tdms_group"] = TDMS_GROUP
        tables["daq"] = daq
        tables["analyzer"] = {"file": files["analyzer"], "format": "vendor_csv"}
    else:
        tables["points"] = {"file": files["points"], "mapping": files["mapping"]}
    tables["sensors"] = {
        "torque_range_nm": 50.0 if motor_side else 100.0,
        "speed_range_rpm": 9000.0 if motor_side else 3000.0,
        "power_range_w": 15000.0,
    }
    return toml_document(top, tables)


def analyzer_preamble(spec: SessionSpec, index: int,
                       inst: ins.Instruments) -> tuple[str, float]:
    """Header block and column rows; also the header's start offset from the DAQ start [s]."""
    # the header shows milliseconds: round the offset, not the wall time's digits
    ms = round(1000.0 * (spec.analyzer_delay_s + spec.analyzer_clock_error_s))
    start = _wall(spec) + timedelta(milliseconds=ms)
    header_offset = (start - _wall(spec)).total_seconds()
    sep = ";" if spec.analyzer_style == "de_w" else ","
    block = [
        ("Yokogawa", "WT1800", "Power Analyzer"), ("Model", "WT1800"),
        ("Serial", f"91M{123456 + 1111 * index}"),
        ("Start Date", start.strftime("%Y/%m/%d")),
        ("Start Time", start.strftime("%H:%M:%S.") + f"{start.microsecond // 1000:03d}"),
        ("Sample Interval", f"{round(inst.analyzer_interval_s * 1000)}ms"), ("Wiring", "3P4W"),
    ]
    lines = [sep.join(row) for row in block] + [""]
    if spec.analyzer_style == "de_w":
        lines += ["Store No.;Zeit;Urms_sigma;Irms_sigma;P_sigma;PF_sigma", ";s;V;A;W;"]
    else:
        unit = "kW" if spec.analyzer_style == "en_kw" else "W"
        lines.append("Store No.,Time [s],Urms_sigma [V],Irms_sigma [A],"
                     f"P_sigma [{unit}],PF_sigma []")
    return "\n".join(lines) + "\n", header_offset


def _daq_stream(spec: SessionSpec, path: Path, inst: ins.Instruments):
    """Open the session's DAQ file writer; returns ``(writer, invalid-value markers)``."""
    if spec.daq_format == "tdms":  # this DAQ logs the winding sensor in kelvin
        channels = [("Time", "s"), ("Speed", "1/min"), ("Torque", "N m"),
                    ("Winding temperature", "K")]
        props = {"name": spec.session_id, "Author": spec.operator, "Bench": "drive test bench"}
        return TdmsStream(path, TDMS_GROUP, channels, props), MARKERS_TDMS
    decimals = (3, inst.speed_decimals, inst.torque_decimals, inst.winding_decimals)
    if spec.daq_format == "csv_de":
        pre = "Zeit;Drehzahl;Drehmoment;Wicklungstemperatur\ns;U/min;Nm;°C\n"
        return CsvStream(path, pre, decimals, sep=";", decimal_mark=","), MARKERS_DE
    if spec.mode == "motor":
        pre = "Time [s],Speed [1/min],Torque [N m],T_winding [degC]\n"
    else:
        pre = "Time [s],Speed [rpm],Torque [Nm],Winding temperature [deg C]\n"
    return CsvStream(path, pre, decimals), MARKERS_EN


def write_daq(seg: Segments, spec: SessionSpec, path: Path, model: LossModel,
              rnd: ins.ChunkRandom, inst: ins.Instruments, progress: tqdm,
              sensor_rng: np.random.Generator) -> int:
    """Write the DAQ stream of one session in chunks; returns the number of rows.

    ``sensor_rng`` is the winding sensor's own random stream (no invalid markers
    in its column, so the other columns' markers are those of a DAQ without it).
    """
    n_rows = int(np.floor(seg.duration_s * inst.daq_rate_hz)) + 1
    writer, kinds = _daq_stream(spec, path, inst)
    sensor = WindingSensor(spec.theta_start_c, inst.winding_lag_s, inst.winding_noise_k,
                           inst.daq_rate_hz, sensor_rng)
    kelvin = KELVIN_AT_0C if spec.daq_format == "tdms" else 0.0
    ok = False
    try:
        for start in range(0, n_rows, DAQ_CHUNK_ROWS):
            rows = slice(start, min(n_rows, start + DAQ_CHUNK_ROWS))
            time_s, speed, torque, theta = ins.daq_chunk(seg, rows, spec, model, rnd, inst)
            winding = np.round(sensor.read(theta) + kelvin, inst.winding_decimals)
            cells = rnd.marker_cells(time_s.size, (1, 2), len(kinds), inst.daq_marker_rate)
            if isinstance(writer, TdmsStream):
                cols = [time_s, speed, torque, winding]
                for c, (r, code) in cells.items():
                    cols[c][r] = np.asarray(kinds)[code]
                writer.write(cols)
            else:
                markers = {c: (r, code, kinds) for c, (r, code) in cells.items()}
                writer.write([time_s, speed, torque, winding], markers)
            progress.update(time_s.size)
        ok = True
    finally:
        writer.close(ok)
    return n_rows


def write_analyzer(seg: Segments, spec: SessionSpec, index: int, path: Path, model: LossModel,
                   rnd: ins.ChunkRandom, inst: ins.Instruments) -> tuple[int, float]:
    """Write the power-analyzer export; returns ``(rows, header start offset [s])``.

    ``index`` (the session's place in the campaign) sets the analyzer's serial number.
    """
    preamble, header_offset = analyzer_preamble(spec, index, inst)
    german = spec.analyzer_style == "de_w"
    kw = spec.analyzer_style == "en_kw"
    decimals = (0, 3, 2, 3, 3 if kw else 0, 4)
    writer = CsvStream(path, preamble, decimals, sep=";" if german else ",",
                       decimal_mark="," if german else ".")
    kinds = MARKERS_DE if german else MARKERS_EN
    n_rows = ins.analyzer_rows(seg, spec, inst)
    state = None
    ok = False
    try:
        for start in range(0, n_rows, ANALYZER_CHUNK_ROWS):
            rows = slice(start, min(n_rows, start + ANALYZER_CHUNK_ROWS))
            (time_s, u, i, p, pf), state = ins.analyzer_chunk(seg, rows, spec, model, rnd,
                                                              state, inst)
            store_no = np.arange(rows.start, rows.stop) + 1
            cells = rnd.marker_cells(time_s.size, (2, 3, 4, 5), len(kinds),
                                     inst.analyzer_marker_rate)
            markers = {c: (r, code, kinds) for c, (r, code) in cells.items()}
            writer.write([store_no, time_s, u, i, p / 1000.0 if kw else p, pf], markers)
        ok = True
    finally:
        writer.close(ok)
    return n_rows, header_offset


_TABLE_COLUMNS = (  # (file column, our quantity, unit, decimals, key of averaged_table, factor)
    ("n_mean", "speed", "1/min", 2, "speed_rpm", 1.0),
    ("n_std", "speed_std", "1/min", 3, "speed_std_rpm", 1.0),
    ("M_mean", "torque", "Nm", 3, "torque_nm", 1.0),
    ("M_std", "torque_std", "Nm", 4, "torque_std_nm", 1.0),
    ("P_el", "p_elec", "kW", 5, "p_elec_w", 1e-3),
    ("P_el_std", "p_elec_std", "kW", 5, "p_elec_std_w", 1e-3),
    ("P_mech", "p_mech", "kW", 5, "p_mech_w", 1e-3),
    ("N", "n_samples", "", 0, "n_samples", 1.0),
)


def write_table(seg: Segments, means: dict, spec: SessionSpec, folder: Path,
                rng: np.random.Generator, inst: ins.Instruments) -> None:
    """Write ``points.csv`` (foreign names, kW) and its ``mapping.toml``."""
    table = ins.averaged_table(seg, means, spec, rng, inst)
    names = ["Pkt"] + [c[0] for c in _TABLE_COLUMNS]
    cols = [np.arange(seg.speed_rpm.size) + 1] + [table[c[4]] * c[5] for c in _TABLE_COLUMNS]
    writer = CsvStream(folder / "points.csv", ",".join(names) + "\n",
                       [0] + [c[3] for c in _TABLE_COLUMNS])
    ok = False
    try:
        writer.write(cols)
        ok = True
    finally:
        writer.close(ok)
    mapping = {f"columns.{q}": {"column": col, "unit": unit}
               for col, q, unit, *_ in _TABLE_COLUMNS}
    write_text_atomic(folder / "mapping.toml", toml_document({}, mapping).lstrip("\n"))
