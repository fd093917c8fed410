"""One reader per source format; each gives ``(data, metadata)``.

- :func:`sniff_csv` / :func:`open_daq_csv`: DAQ CSV, English (``,`` / ``.``) or German
  (``;`` / ``,`` and a units row), streamed in byte chunks parsed by pyarrow's
  multithreaded C++ CSV parser with explicit float64 column types.
- :func:`open_daq_tdms`: NI TDMS through npTDMS, streamed channel chunk by chunk.
- :func:`read_analyzer`: power-analyzer vendor CSV (``key,value`` header block).
- :func:`read_points_table`: table of pre-averaged operating points.

Streams yield :class:`Chunk` objects so memory does not grow with file size.
Values come out in our units (s, rpm, N m, W) with invalid markers as NaN.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from datetime import datetime
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv

from bench.ingest import clock
from bench.ingest.mapping import (
    COUNTER,
    EMPTY_MAPPING,
    Mapping,
    ResolvedColumn,
    closest_columns,
    resolve_columns,
)
from bench.ingest.scrub import NULL_MARKERS, scrub
from kernel.errors import InputError

#: CSV bytes parsed per chunk; bounds the memory of the first pass [B]
CHUNK_BYTES = 16 * 1024 * 1024
_SNIFF_BYTES = 64 * 1024
#: longest accepted line (names row or data row) [B]; a longer one is a damaged file
MAX_LINE_BYTES = 1024 * 1024
#: lines sniffing wants to see (preamble, names, units, rows for the decimal mark)
_SNIFF_LINES = 64


@dataclass(frozen=True)
class CsvLayout:
    """What sniffing found out about a delimited text file.

    Parameters
    ----------
    path : Path
        The file.
    sep, decimal : str
        Field separator and decimal mark.
    encoding : str
        Text encoding of the header lines.
    headers : list of str
        Column names.
    units_row : list of str or None
        The units row under the names (German exports), else None.
    header_line : int
        1-based line number of the names row.
    data_line : int
        1-based line number of the first data row.
    data_offset : int
        Byte offset of the first data row.
    preamble : dict
        ``key -> value`` lines before the names row (analyzer header block).
    samples : list of list of str
        Cells of the first data rows (to tell clock-time columns from numbers).
    """

    path: Path
    sep: str
    decimal: str
    encoding: str
    headers: list[str]
    units_row: list[str] | None
    header_line: int
    data_line: int
    data_offset: int
    preamble: dict[str, str] = field(default_factory=dict)
    samples: list[list[str]] = field(default_factory=list)

    def units_with_clock(self) -> list[str] | None:
        """The units row, with the clock format put in for columns whose data are clock times
        (None when there is neither)."""
        units = list(self.units_row) if self.units_row is not None else [""] * len(self.headers)
        found = False
        for i in range(len(self.headers)):
            fmt = clock.detect([r[i] for r in self.samples if i < len(r)])
            if fmt is not None:
                units[i] = fmt
                found = True
        return units if found or self.units_row is not None else None


@dataclass(frozen=True)
class Chunk:
    """A block of rows from a stream, in our units.

    Parameters
    ----------
    row0 : int
        0-based index of its first data row within the file.
    values : dict
        quantity -> float64 array.
    nbytes : int
        Bytes of the source this chunk covers (for progress bars).
    """

    row0: int
    values: dict[str, np.ndarray]
    nbytes: int


def _check_text(path: Path, head: bytes) -> str:
    """Reject empty, binary, UTF-16 and CR-only files; return the text encoding of ``head``."""
    if not head.strip():
        raise InputError(path, "file is empty", expected="a text file with a header row and data")
    even, odd = head[0:4096:2], head[1:4096:2]
    if head[:2] in (b"\xff\xfe", b"\xfe\xff") or (
            len(head) > 16 and max(even.count(0), odd.count(0)) > 0.4 * len(odd)):
        raise InputError(path, "UTF-16 text, not UTF-8 or a single-byte encoding", line=1,
                         expected="the file re-saved as UTF-8 (e.g. Excel: CSV UTF-8; "
                                  "iconv -f UTF-16 -t UTF-8)")
    if b"\r" in head and b"\n" not in head:
        raise InputError(path, "lines end in CR only (classic Mac line ends)", line=1,
                         expected="LF or CRLF line ends (re-save the file, or "
                                  "tr '\\r' '\\n' < in > out)")
    ctrl = sum(1 for b in head if b < 32 and b not in (9, 10, 13))
    if b"\x00" in head or ctrl > 0.01 * len(head):
        raise InputError(
            path, "binary file, not a delimited text file", line=1,
            expected="CSV text (is this a TDMS or spreadsheet file with a .csv name?)",
        )
    try:
        head.decode("utf-8")
        return "utf-8"
    except UnicodeDecodeError as exc:
        if exc.start >= len(head) - 4:  # a character cut by the sniff window
            return "utf-8"
        return "cp1252"


def _split(line: str, sep: str) -> list[str]:
    return [f.strip().strip('"') for f in line.rstrip("\r\n").split(sep)]


def _is_number(text: str, decimal: str) -> bool:
    t = text.strip()
    if t.upper() in {m.upper() for m in NULL_MARKERS}:
        return True
    if decimal == ",":
        if "." in t:  # an English decimal in a German file
            return False
        t = t.replace(",", ".")
    try:
        float(t)
    except ValueError:
        return False
    return True


def _guess_sep(line: str) -> str:
    counts = {s: line.count(s) for s in (";", "\t", ",")}
    sep = max(counts, key=counts.get)
    return sep if counts[sep] > 0 else ","


def _guess_decimal(sep: str, sample_rows: list[str]) -> str:
    if sep == ",":
        return "."
    joined = "\n".join(sample_rows)
    return "," if re.search(r"\d,\d", joined) and not re.search(r"\d\.\d", joined) else "."


def sniff_csv(path: str | Path, preamble: bool = False, skip_lines: int = 0) -> CsvLayout:
    """Sniff separator, decimal mark, names row and optional units row of a CSV file.

    Parameters
    ----------
    path : str or Path
        The file. Its name is not trusted: the content decides.
    preamble : bool
        True for analyzer exports: ``key,value`` lines and a blank line come
        before the names row.
    skip_lines : int
        Lines at the top to pass over before anything else (a title or date
        line; the mapping's ``skip_lines``).

    Raises
    ------
    InputError
        Empty or binary file, missing names row, or no data rows.
    """
    path = Path(path)
    window = _SNIFF_BYTES
    try:
        with path.open("rb") as fh:
            head = fh.read(window)
            # a long names row (thousands of channels) needs a wider window, up to a bound
            while len(head) == window and head.count(b"\n") < _SNIFF_LINES \
                    and window < 4 * MAX_LINE_BYTES:
                head += fh.read(window)
                window *= 2
    except OSError as exc:
        raise InputError(path, f"cannot read file ({exc})") from exc
    encoding = _check_text(path, head)
    raw_lines = head.split(b"\n")
    cut = len(head) == window
    if cut:
        raw_lines = raw_lines[:-1]  # the last line may be cut by the sniff window
    too_long = [k for k, ln in enumerate(raw_lines) if len(ln) > MAX_LINE_BYTES]
    if too_long or (cut and len(head) - sum(len(ln) + 1 for ln in raw_lines) > MAX_LINE_BYTES):
        k = too_long[0] if too_long else len(raw_lines)
        raise InputError(path, f"line longer than {MAX_LINE_BYTES // 1024} KiB", line=k + 1,
                         expected="a delimited text file (a damaged or binary file?)")
    lines = [ln.decode(encoding, errors="replace") for ln in raw_lines]
    if lines and lines[0].startswith("\ufeff"):  # a UTF-8 byte-order mark (Excel exports)
        lines[0] = lines[0][1:]
    offsets = np.cumsum([0] + [len(ln) + 1 for ln in raw_lines]).tolist()

    if skip_lines >= len(lines):
        raise InputError(path, f"skip_lines = {skip_lines} passes over the whole header "
                         f"({len(lines)} lines read)", expected="the number of lines before the "
                         "column row (a title or date line)")
    idx = skip_lines
    meta: dict[str, str] = {}
    if preamble:
        while idx < len(lines) and lines[idx].strip():
            sep0 = _guess_sep(lines[idx])
            parts = _split(lines[idx], sep0)
            meta[parts[0]] = sep0.join(parts[1:]) if len(parts) > 1 else ""
            idx += 1
        if idx >= len(lines):
            raise InputError(
                path, "no blank line after the header block", line=idx,
                expected="'key,value' lines, a blank line, then the column row",
            )
    while idx < len(lines) and not lines[idx].strip():
        idx += 1
    if idx >= len(lines):
        raise InputError(path, "no column row", expected="a row of column names")
    header_idx = idx
    sep = _guess_sep(lines[header_idx])
    headers = _split(lines[header_idx], sep)
    rest = [ln for ln in lines[header_idx + 1 : header_idx + 40] if ln.strip()]
    decimal = _guess_decimal(sep, rest[1:] if len(rest) > 1 else rest)
    units_row = None
    data_idx = header_idx + 1
    if data_idx < len(lines) and lines[data_idx].strip():
        cells = _split(lines[data_idx], sep)
        if not any(c and _is_number(c, decimal) for c in cells):
            units_row = cells
            data_idx += 1
    while data_idx < len(lines) and not lines[data_idx].strip():
        data_idx += 1
    if data_idx >= len(lines) or not lines[data_idx].strip():
        raise InputError(path, "no data rows", line=header_idx + 1,
                         expected="data under the header")
    n_data = len(_split(lines[data_idx], sep))
    if len(headers) == 1 < n_data:  # one field: a title line (extra fields are caught later)
        raise InputError(
            path, f"the column row (line {header_idx + 1}) has {len(headers)} field(s) but the "
            f"data rows have {n_data}: is line {header_idx + 1} a title or date line?",
            line=header_idx + 1,
            expected="skip_lines = N in the mapping file (the lines before the column row)",
        )
    samples = [_split(ln, sep) for ln in lines[data_idx:data_idx + 20] if ln.strip()]
    return CsvLayout(
        path=path, sep=sep, decimal=decimal, encoding=encoding, headers=headers,
        units_row=units_row, header_line=header_idx + 1, data_line=data_idx + 1,
        data_offset=offsets[data_idx], preamble=meta, samples=samples,
    )


def _locate_bad_row(
    layout: CsvLayout, buf: bytes, first_line: int, cols: dict[str, ResolvedColumn]
) -> InputError:
    """Find the first malformed row of ``buf`` (slow path, only after a parse error)."""
    n = len(layout.headers)
    for k, raw in enumerate(buf.split(b"\n")):
        line = raw.decode(layout.encoding, errors="replace").rstrip("\r")
        if not line.strip():
            continue
        cells = _split(line, layout.sep)
        if len(cells) != n:
            what = "truncated row?" if len(cells) < n else "extra fields"
            return InputError(
                layout.path, f"row has {len(cells)} fields ({what})", line=first_line + k,
                expected=f"{n} fields separated by {layout.sep!r}",
            )
        for i in sorted({i for res in cols.values() for i in res.indices}):
            cell = cells[i]
            if cell and not _is_number(cell, layout.decimal):
                return InputError(
                    layout.path, f"not a number: {cell!r}", line=first_line + k,
                    column=layout.headers[i],
                    expected=f"a number with decimal mark {layout.decimal!r} or an invalid marker",
                )
    return InputError(layout.path, "cannot parse CSV data", line=first_line)


def clock_parsers(layout: CsvLayout, cols: dict[str, ResolvedColumn],
                  day=None) -> dict[str, clock.ClockParser]:
    """A :class:`clock.ClockParser` for the time column when it holds clock times (its unit
    names a clock format, or its first cells are clock times); with a sample counter
    mapped, repeated stamps are not spread (the counter places the rows)."""
    r = cols["time"]
    if r.formula is not None:
        return {}
    fmt = clock.normalise_unit(r.unit) or clock.detect(
        [row[r.index] for row in layout.samples if r.index < len(row)])
    if fmt is None:
        return {}
    return {"time": clock.ClockParser(fmt, day, spread=COUNTER not in cols)}


def iter_csv(
    layout: CsvLayout,
    cols: dict[str, ResolvedColumn],
    chunk_bytes: int = CHUNK_BYTES,
    clocks: dict[str, clock.ClockParser] | None = None,
) -> Iterator[Chunk]:
    """Stream the data rows of a sniffed CSV in chunks, converted to our units.

    Parameters
    ----------
    layout : CsvLayout
        From :func:`sniff_csv`.
    cols : dict
        quantity -> :class:`ResolvedColumn` (from :func:`resolve_columns`).
    chunk_bytes : int
        Approximate bytes per chunk [B].
    clocks : dict, optional
        quantity -> :class:`clock.ClockParser` for clock-time columns (read as text,
        turned into seconds since the first valid time).

    Yields
    ------
    Chunk
        Rows with invalid markers turned into NaN.

    Raises
    ------
    InputError
        A row with the wrong number of fields (truncated file) or a cell that is
        not a number, naming its line.
    """
    names = [f"c{i}" for i in range(len(layout.headers))]
    read_cols = sorted({names[i] for r in cols.values() for i in r.indices})
    read_opts = pacsv.ReadOptions(column_names=names, use_threads=True, block_size=1 << 22)
    parse_opts = pacsv.ParseOptions(delimiter=layout.sep, quote_char='"')
    clocks = clocks or {}
    clock_cols = {names[cols[q].index] for q in clocks}
    conv_opts = pacsv.ConvertOptions(
        column_types={c: pa.string() if c in clock_cols else pa.float64() for c in read_cols},
        include_columns=read_cols,
        null_values=list(NULL_MARKERS),
        strings_can_be_null=True,
        decimal_point=layout.decimal,
    )
    row0 = 0
    offset = layout.data_offset  # file offset of the chunk being parsed
    buf = bytearray(chunk_bytes)
    view = memoryview(buf)
    with layout.path.open("rb") as fh:
        fh.seek(offset)
        carry = 0  # bytes of an incomplete last line kept at the front of buf
        while True:
            if carry >= MAX_LINE_BYTES:  # no line end in that many bytes
                raise InputError(layout.path, f"line longer than {MAX_LINE_BYTES // 1024} "
                                 "KiB", line=_line_at(layout, offset),
                                 expected="a delimited text file (a damaged file?)")
            if carry == len(buf):  # a single line longer than the buffer
                buf.extend(bytes(len(buf)))
                view.release()
                view = memoryview(buf)
            got = fh.readinto(view[carry:])
            filled = carry + got
            if filled == 0:
                break
            end = filled if got == 0 else buf.rfind(b"\n", 0, filled) + 1
            if end == 0:
                carry = filled
                continue
            try:
                table = pacsv.read_csv(
                    pa.py_buffer(view[:end]), read_options=read_opts,
                    parse_options=parse_opts, convert_options=conv_opts,
                )
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
                raise _locate_bad_row(layout, bytes(view[:end]), _line_at(layout, offset),
                                      cols) from exc
            values = quantities({q: r for q, r in cols.items() if q not in clocks},
                                partial(_column_at, table, names))
            for q, parse in clocks.items():
                cells = table.column(names[cols[q].index]).combine_chunks()
                try:
                    values[q] = parse(cells)
                except ValueError as exc:
                    raise _bad_clock_cell(layout, cells, parse.unit, _line_at(layout, offset),
                                          cols[q].header) from exc
            if COUNTER in values:  # the stamp plus the row's place within it
                values["time"] = values["time"] + values.pop(COUNTER)
            values = {q: values[q] for q in cols if q != COUNTER}
            del table
            if values and next(iter(values.values())).size:
                yield Chunk(row0=row0, values=values, nbytes=end)
                row0 += next(iter(values.values())).size
            offset += end
            carry = filled - end
            if carry:
                buf[:carry] = buf[end:filled]
            if got == 0:
                break
    view.release()


def _bad_clock_cell(layout: CsvLayout, cells: pa.Array, unit: str, first_line: int,
                    header: str) -> InputError:
    """The first cell of a chunk that is not a clock time of ``unit`` (slow path)."""
    for k, cell in enumerate(cells.to_pylist()):
        if cell is not None and clock.detect([cell]) != unit:
            return InputError(layout.path, f"not a clock time: {cell!r}", line=first_line + k,
                              column=header, expected=f"a {unit} time like the rows above")
    return InputError(layout.path, f"cannot read the {unit} times", line=first_line,
                      column=header, expected=f"{unit} times")


def quantities(
    cols: dict[str, ResolvedColumn], column: Callable[[int], np.ndarray]
) -> dict[str, np.ndarray]:
    """Each quantity in our unit from ``column(index)`` (a file column, invalid as NaN).

    Sums and expressions are evaluated here; each file column is read once.
    """
    cache: dict[int, np.ndarray] = {}

    def get(i: int) -> np.ndarray:
        if i not in cache:
            cache[i] = column(i)
        return cache[i]

    return {q: r.values(get) for q, r in cols.items()}


def _column_at(table: pa.Table, names: list[str], i: int) -> np.ndarray:
    """File column ``i`` of a parsed chunk as float64 numpy, invalid markers as NaN."""
    return scrub(table.column(names[i]).to_numpy(zero_copy_only=False))


def _line_at(layout: CsvLayout, offset: int) -> int:
    """1-based line number of the line starting at byte ``offset`` (slow path)."""
    n, left = 0, offset - layout.data_offset
    with layout.path.open("rb") as fh:
        fh.seek(layout.data_offset)
        while left > 0:
            block = fh.read(min(left, 1 << 20))
            if not block:
                break
            n += block.count(b"\n")
            left -= len(block)
    return layout.data_line + n


def line_of_row(layout: CsvLayout, row: int) -> int:
    """1-based line number of 0-based data row ``row`` (skips blank lines; slow path)."""
    with layout.path.open("rb") as fh:
        fh.seek(layout.data_offset)
        seen = -1
        for k, raw in enumerate(fh):
            if raw.strip():
                seen += 1
                if seen == row:
                    return layout.data_line + k
    return layout.data_line + row


def csv_columns_meta(cols: dict[str, ResolvedColumn]) -> dict[str, dict[str, str]]:
    """quantity -> ``{"column": header, "unit": unit}`` for the manifest."""
    return {q: {"column": r.header, "unit": r.unit} for q, r in cols.items()}


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
        required=required, optional=optional + (COUNTER,), mapping=mapping,
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


def open_daq_tdms(
    path: str | Path, group: str, mapping: Mapping = EMPTY_MAPPING,
    chunk_rows: int = TDMS_CHUNK_ROWS,
) -> DaqStream:
    """Open a TDMS DAQ file (npTDMS, streaming) as a chunked stream of time, speed, torque.

    Channels are found by the mapping (``[daq.columns.*] column`` = channel name)
    or by name (``Time``, ``Speed``, ``Torque``); units come from each channel's
    ``unit_string`` property unless the mapping gives one.
    """
    from nptdms import TdmsFile

    path = Path(path)
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
    cols = resolve_columns(path, headers, units, "daq", required=("time", "speed", "torque"),
                           mapping=mapping)
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


def _read_all(layout: CsvLayout, cols: dict[str, ResolvedColumn],
              clocks: dict[str, clock.ClockParser] | None = None) -> dict[str, np.ndarray]:
    parts = [p.values for p in iter_csv(layout, cols, clocks=clocks)]
    out = {}
    for q in cols:  # one column at a time: its chunks are freed before the next is joined
        out[q] = np.concatenate([p.pop(q) for p in parts])
    return out


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
    data = _read_all(layout, cols, clocks)
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
    data = _read_all(layout, cols)
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
