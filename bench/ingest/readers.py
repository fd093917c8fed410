"""Whole-file readers of a session's tables; each gives ``(frame, metadata)``.

- :func:`read_analyzer`: power-analyzer vendor CSV (``key,value`` header block).
- :func:`read_points_table`: table of pre-averaged operating points.

The DAQ stream, read in chunks, is opened by :mod:`bench.ingest.daq_stream`; the CSV
sniffing and streaming both use are :mod:`bench.ingest.csv_layout` and
:mod:`bench.ingest.csv_stream`. Values come out in our units (s, rpm, N m, W) with
invalid markers as NaN.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pandas as pd

from bench.ingest import clock
from bench.ingest.csv_layout import sniff_csv
from bench.ingest.csv_stream import clock_parsers, csv_columns_meta, read_all
from bench.ingest.mapping import COUNTER, EMPTY_MAPPING, Mapping, resolve_columns

_DATE_FORMATS = ("%Y/%m/%d", "%Y-%m-%d", "%d.%m.%Y", "%m/%d/%Y")


_TIME_FORMATS = ("%H:%M:%S.%f", "%H:%M:%S,%f", "%H:%M:%S")


def _parse_wall_time(date: str, time: str) -> datetime | None:
    for df in _DATE_FORMATS:
        for tf in _TIME_FORMATS:
            try:
                return datetime.strptime(f"{date.strip()} {time.strip()}", f"{df} {tf}")
            except ValueError:
                continue
    return None


def read_analyzer(
    path: str | Path, mapping: Mapping = EMPTY_MAPPING, day=None
) -> tuple[pd.DataFrame, dict]:
    """Read a power-analyzer vendor CSV export.

    ``day`` (the session's date) dates a time-of-day time column; the wall
    times of a clock-time column then give ``start``, else the header block's
    ``Start Date`` and ``Start Time`` do.

    Returns
    -------
    frame : pandas.DataFrame
        ``time_s`` (analyzer clock) and ``p_elec_w`` (positive = drawn from grid).
    metadata : dict
        The header block (``Model``, ``Serial``, ...), ``start`` (ISO wall time of
        the analyzer's time 0, or None), separator, decimal and columns.
    """
    layout = sniff_csv(path, preamble=True, skip_lines=mapping.skip("analyzer"))
    cols = resolve_columns(
        layout.path, layout.headers, layout.units_with_clock(), "analyzer",
        required=("time", "p_elec"), optional=(COUNTER,), mapping=mapping,
        header_line=layout.header_line,
    )
    clocks = clock_parsers(layout, cols, day)
    data = read_all(layout, cols, clocks)
    pre = {k.strip(): v.strip() for k, v in layout.preamble.items()}
    start = None
    if "time" in clocks and (day is not None or clocks["time"].unit == clock.DATETIME):
        start = clocks["time"].start  # the record's own wall times win over the header
    elif "Start Date" in pre and "Start Time" in pre:
        start = _parse_wall_time(pre["Start Date"], pre["Start Time"])
    meta = {
        "format": "vendor_csv", "header": pre,
        "start": None if start is None else start.isoformat(),
        "separator": layout.sep, "decimal": layout.decimal, "columns": csv_columns_meta(cols),
        "layout": layout,
    }
    frame = pd.DataFrame({"time_s": data["time"], "p_elec_w": data["p_elec"]}, copy=False)
    return frame, meta


POINT_OPTIONAL = ("p_mech", "speed_std", "torque_std", "p_elec_std", "p_mech_std", "n_samples")


def read_points_table(
    path: str | Path, mapping: Mapping = EMPTY_MAPPING
) -> tuple[pd.DataFrame, dict]:
    """Read a table of pre-averaged operating points (one row per point).

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``speed_rpm``, ``torque_nm``, ``p_elec_w`` and, when present,
        ``p_mech_w``, the ``*_std`` columns and ``n_samples``; logged signs (not
        yet in the drum frame).
    metadata : dict
        Separator, decimal and the columns used with their units.
    """
    layout = sniff_csv(path, skip_lines=mapping.skip("points"))
    cols = resolve_columns(
        layout.path, layout.headers, layout.units_with_clock(), "points",
        required=("speed", "torque", "p_elec"), optional=POINT_OPTIONAL,
        mapping=mapping, header_line=layout.header_line,
    )
    data = read_all(layout, cols)
    names = {
        "speed": "speed_rpm", "torque": "torque_nm", "p_elec": "p_elec_w", "p_mech": "p_mech_w",
        "speed_std": "speed_rpm_std", "torque_std": "torque_nm_std",
        "p_elec_std": "p_elec_w_std", "p_mech_std": "p_mech_w_std", "n_samples": "n_samples",
    }
    frame = pd.DataFrame({names[q]: v for q, v in data.items()})
    meta = {
        "format": "operating_point_table", "separator": layout.sep, "decimal": layout.decimal,
        "columns": csv_columns_meta(cols), "layout": layout,
    }
    return frame, meta
