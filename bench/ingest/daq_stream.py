"""The DAQ stream of a timeseries session (or its single-stream log), opened: metadata
now, chunks of time, speed and torque on demand, from a CSV file
(:mod:`bench.ingest.csv_stream`) or an NI TDMS file (npTDMS, channel chunk by chunk)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.ingest import clock
from bench.ingest.csv_layout import line_of_row, sniff_csv
from bench.ingest.csv_stream import (
    CHUNK_BYTES,
    Chunk,
    clock_parsers,
    csv_columns_meta,
    iter_csv,
    quantities,
)
from bench.ingest.mapping import (
    COUNTER,
    EMPTY_MAPPING,
    Mapping,
    closest_columns,
    resolve_columns,
)
from bench.ingest.scrub import scrub
from bench.ingest.temperature import TEMPERATURES
from kernel.errors import InputError


@dataclass
class DaqStream:
    """An opened DAQ stream (or single-stream log): metadata now, chunks on demand.

    Parameters
    ----------
    path : Path
        The file.
    metadata : dict
        Format, separator/decimal or TDMS group, columns and units.
    size_bytes : int
        File size, for progress bars.
    chunks : callable
        ``chunks() -> Iterator[Chunk]`` with ``time``, ``speed``, ``torque`` (and
        whatever else the stream was opened for).
    line_of_row : callable
        ``line_of_row(row) -> int or None`` to place errors.
    clock : clock.ClockParser or None
        The parser of a clock-time time column; its ``start`` (the wall time of
        time 0) is known once the first chunk is read.
    """

    path: Path
    metadata: dict
    size_bytes: int
    chunks: object
    line_of_row: object
    clock: clock.ClockParser | None = None


def open_daq_csv(
    path: str | Path, mapping: Mapping = EMPTY_MAPPING, chunk_bytes: int = CHUNK_BYTES,
    day=None, section: str = "daq", required: tuple[str, ...] = ("time", "speed", "torque"),
    optional: tuple[str, ...] = (),
) -> DaqStream:
    """Open a DAQ CSV (English or German locale) as a chunked stream of time, speed, torque.

    Parameters
    ----------
    path : str or Path
        The file.
    mapping : Mapping
        Column mapping (section ``section``).
    chunk_bytes : int
        Bytes per chunk [B].
    day : datetime.date, optional
        The date of a time-of-day time column (the session's ``date``).
    section, required, optional : str, tuple of str, tuple of str
        Mapping section and the quantities to read (a single-stream log reads
        ``p_elec`` too, and ``p_mech`` when mapped).
    """
    layout = sniff_csv(path, skip_lines=mapping.skip(section))
    cols = resolve_columns(
        layout.path, layout.headers, layout.units_with_clock(), section,
        required=required, optional=optional + (COUNTER, *TEMPERATURES), mapping=mapping,
        header_line=layout.header_line,
    )
    clocks = clock_parsers(layout, cols, day)
    meta = {
        "format": "csv", "separator": layout.sep, "decimal": layout.decimal,
        "encoding": layout.encoding, "columns": csv_columns_meta(cols),
    }
    return DaqStream(
        path=layout.path, metadata=meta, size_bytes=layout.path.stat().st_size,
        chunks=lambda: iter_csv(layout, cols, chunk_bytes, clocks),
        line_of_row=lambda row: line_of_row(layout, row), clock=clocks.get("time"),
    )


#: TDMS channel values read per chunk
TDMS_CHUNK_ROWS = 2_000_000


def _tdms_channels(path: Path, group: str) -> tuple[list[str], list[str], dict[str, int]]:
    """The names, units (``unit_string``) and lengths of a TDMS group's channels.

    Raises
    ------
    InputError
        Unreadable, empty or not TDMS, no such group, a damaged file.
    """
    from nptdms import TdmsFile

    try:
        with path.open("rb") as fh:
            head = fh.read(4)
    except OSError as exc:
        raise InputError(path, f"cannot read file ({exc})") from exc
    if not head:
        raise InputError(path, "file is empty", expected="a TDMS file")
    if head != b"TDSm":
        raise InputError(path, "not a TDMS file (no 'TDSm' lead-in)", expected="an NI TDMS file")
    try:
        with TdmsFile.open(path) as tdms:
            names = [g.name for g in tdms.groups()]
            if not names:
                raise InputError(path, "TDMS file holds no groups (truncated file?)",
                                 expected=f"a group {group!r} with Time, Speed, Torque")
            if group not in names:
                raise InputError(path, f"no TDMS group {group!r}", column=group,
                                 expected=closest_columns([group], names, what="groups"))
            channels = tdms[group].channels()
            headers = [c.name for c in channels]
            units = [str(c.properties.get("unit_string", "")) for c in channels]
            lengths = {c.name: len(c) for c in channels}
    except InputError:
        raise
    except Exception as exc:  # npTDMS raises several types for a damaged file
        raise InputError(path, f"unreadable TDMS file ({exc})",
                         expected="an NI TDMS file written completely") from exc
    return headers, units, lengths


def open_daq_tdms(
    path: str | Path, group: str, mapping: Mapping = EMPTY_MAPPING,
    chunk_rows: int = TDMS_CHUNK_ROWS,
) -> DaqStream:
    """Open a TDMS DAQ file (npTDMS, streaming) as a chunked stream of time, speed, torque.

    Channels are found by the mapping (``[daq.columns.*] column`` = channel name)
    or by name (``Time``, ``Speed``, ``Torque``); units come from each channel's
    ``unit_string`` property unless the mapping gives one.
    """
    path = Path(path)
    headers, units, lengths = _tdms_channels(path, group)
    cols = resolve_columns(path, headers, units, "daq", required=("time", "speed", "torque"),
                           optional=TEMPERATURES, mapping=mapping)
    n_rows = {lengths[headers[i]] for r in cols.values() for i in r.indices}
    if len(n_rows) != 1:
        raise InputError(path, f"channels of group {group!r} differ in length {sorted(n_rows)}"
                         " (truncated file?)", expected="Time, Speed and Torque of equal length")
    n = n_rows.pop()
    if n == 0:
        raise InputError(path, "TDMS channels hold no data", expected="data samples")
    size = path.stat().st_size

    def read(grp, name: str, start: int, length: int) -> np.ndarray:
        try:
            return np.asarray(grp[name].read_data(start, length), dtype=np.float64)
        except Exception as exc:  # a truncated or damaged data segment
            raise InputError(path, f"unreadable TDMS data at sample {start} ({exc})",
                             column=name, expected="an NI TDMS file written completely") from exc

    def chunks() -> Iterator[Chunk]:
        from nptdms import TdmsFile

        with TdmsFile.open(path) as tdms_file:
            grp = tdms_file[group]
            for start in range(0, n, chunk_rows):
                length = min(chunk_rows, n - start)
                values = quantities(cols, lambda i, s=start, n=length: scrub(
                    read(grp, headers[i], s, n)))
                yield Chunk(row0=start, values=values, nbytes=int(size * length / n))

    meta = {"format": "tdms", "group": group, "columns": csv_columns_meta(cols), "rows": n}
    return DaqStream(path=path, metadata=meta, size_bytes=size, chunks=chunks,
                     line_of_row=lambda row: None)
