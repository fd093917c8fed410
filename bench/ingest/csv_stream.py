"""Streaming the data rows of a sniffed CSV (:mod:`bench.ingest.csv_layout`) in byte
chunks, parsed by pyarrow's multithreaded C++ CSV parser with explicit float64 column
types, converted to our units (s, rpm, N m, W) with invalid markers as NaN."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from bench.ingest import clock
from bench.ingest.csv_layout import MAX_LINE_BYTES, CsvLayout, is_number, line_at, split_cells
from bench.ingest.mapping import COUNTER, ResolvedColumn
from bench.ingest.scrub import NULL_MARKERS, scrub
from kernel.errors import InputError

#: CSV bytes parsed per chunk; bounds the memory of the first pass [B]
CHUNK_BYTES = 16 * 1024 * 1024


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


def _locate_bad_row(
    layout: CsvLayout, buf: bytes, first_line: int, cols: dict[str, ResolvedColumn]
) -> InputError:
    """Find the first malformed row of ``buf`` (slow path, only after a parse error)."""
    n = len(layout.headers)
    for k, raw in enumerate(buf.split(b"\n")):
        line = raw.decode(layout.encoding, errors="replace").rstrip("\r")
        if not line.strip():
            continue
        cells = split_cells(line, layout.sep)
        if len(cells) != n:
            what = "truncated row?" if len(cells) < n else "extra fields"
            return InputError(
                layout.path, f"row has {len(cells)} fields ({what})", line=first_line + k,
                expected=f"{n} fields separated by {layout.sep!r}",
            )
        for i in sorted({i for res in cols.values() for i in res.indices}):
            cell = cells[i]
            if cell and not is_number(cell, layout.decimal):
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


def csv_columns_meta(cols: dict[str, ResolvedColumn]) -> dict[str, dict[str, str]]:
    """quantity -> ``{"column": header, "unit": unit}`` for the manifest."""
    return {q: {"column": r.header, "unit": r.unit} for q, r in cols.items()}


class _BlockParser:
    """Parses blocks of whole data rows of a sniffed CSV into our quantities (pyarrow's CSV
    reader with explicit column types; clock-time columns read as text and parsed)."""

    def __init__(self, layout: CsvLayout, cols: dict[str, ResolvedColumn],
                 clocks: dict[str, clock.ClockParser]) -> None:
        self.layout, self.cols, self.clocks = layout, cols, clocks
        self.names = names = [f"c{i}" for i in range(len(layout.headers))]
        read_cols = sorted({names[i] for r in cols.values() for i in r.indices})
        self.read_opts = pacsv.ReadOptions(column_names=names, use_threads=True,
                                           block_size=1 << 22)
        self.parse_opts = pacsv.ParseOptions(delimiter=layout.sep, quote_char='"')
        clock_cols = {names[cols[q].index] for q in clocks}
        self.conv_opts = pacsv.ConvertOptions(
            column_types={c: pa.string() if c in clock_cols else pa.float64()
                          for c in read_cols},
            include_columns=read_cols,
            null_values=list(NULL_MARKERS),
            strings_can_be_null=True,
            decimal_point=layout.decimal,
        )

    def __call__(self, block: memoryview, offset: int) -> dict[str, np.ndarray]:
        """The quantities of the rows in ``block``, which starts at byte ``offset``.

        Raises
        ------
        InputError
            A malformed row or cell, naming its line.
        """
        layout, cols, names = self.layout, self.cols, self.names
        try:
            table = pacsv.read_csv(
                pa.py_buffer(block), read_options=self.read_opts,
                parse_options=self.parse_opts, convert_options=self.conv_opts,
            )
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
            raise _locate_bad_row(layout, bytes(block), line_at(layout, offset),
                                  cols) from exc
        values = quantities({q: r for q, r in cols.items() if q not in self.clocks},
                            partial(_column_at, table, names))
        for q, parse in self.clocks.items():
            cells = table.column(names[cols[q].index]).combine_chunks()
            try:
                values[q] = parse(cells)
            except ValueError as exc:
                raise _bad_clock_cell(layout, cells, parse.unit, line_at(layout, offset),
                                      cols[q].header) from exc
        if COUNTER in values:  # the stamp plus the row's place within it
            values["time"] = values["time"] + values.pop(COUNTER)
        return {q: values[q] for q in cols if q != COUNTER}


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
    clocks = clocks or {}
    parse = _BlockParser(layout, cols, clocks)
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
                                 "KiB", line=line_at(layout, offset),
                                 expected="a delimited text file (a damaged file?)")
            if carry == len(buf):  # a single line longer than the buffer: grow it
                view.release()  # (a bytearray with a live view cannot be resized)
                buf.extend(bytes(len(buf)))
                view = memoryview(buf)
            got = fh.readinto(view[carry:])
            filled = carry + got
            if filled == 0:
                break
            end = filled if got == 0 else buf.rfind(b"\n", 0, filled) + 1
            if end == 0:
                carry = filled
                continue
            values = parse(view[:end], offset)
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


def read_all(layout: CsvLayout, cols: dict[str, ResolvedColumn],
              clocks: dict[str, clock.ClockParser] | None = None) -> dict[str, np.ndarray]:
    """Every data row of a sniffed CSV at once, quantity -> values in our units."""
    parts = [p.values for p in iter_csv(layout, cols, clocks=clocks)]
    out = {}
    for q in cols:  # one column at a time: its chunks are freed before the next is joined
        out[q] = np.concatenate([p.pop(q) for p in parts])
    return out
