"""Sniffing a delimited text file: encoding, separator, decimal mark, the names row, an
optional units row and header block, where the data begin; line numbers for errors."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bench.ingest import clock
from bench.ingest.scrub import NULL_MARKERS
from kernel.errors import InputError

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


def split_cells(line: str, sep: str) -> list[str]:
    return [f.strip().strip('"') for f in line.rstrip("\r\n").split(sep)]


def is_number(text: str, decimal: str) -> bool:
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


def _header_lines(path: Path) -> tuple[list[str], list[int], str]:
    """The lines at the top of the file, decoded, their byte offsets and the encoding.

    Raises
    ------
    InputError
        Unreadable, empty, binary, UTF-16 or CR-only file, or a line longer than
        :data:`MAX_LINE_BYTES`.
    """
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
    return lines, offsets, encoding


def _preamble(path: Path, lines: list[str], idx: int) -> tuple[int, dict[str, str]]:
    """The ``key,value`` header block from line ``idx`` (0-based) to a blank line; the
    index after it."""
    meta: dict[str, str] = {}
    while idx < len(lines) and lines[idx].strip():
        sep0 = _guess_sep(lines[idx])
        parts = split_cells(lines[idx], sep0)
        meta[parts[0]] = sep0.join(parts[1:]) if len(parts) > 1 else ""
        idx += 1
    if idx >= len(lines):
        raise InputError(
            path, "no blank line after the header block", line=idx,
            expected="'key,value' lines, a blank line, then the column row",
        )
    return idx, meta


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
    lines, offsets, encoding = _header_lines(path)
    if skip_lines >= len(lines):
        raise InputError(path, f"skip_lines = {skip_lines} passes over the whole header "
                         f"({len(lines)} lines read)", expected="the number of lines before the "
                         "column row (a title or date line)")
    idx, meta = _preamble(path, lines, skip_lines) if preamble else (skip_lines, {})
    while idx < len(lines) and not lines[idx].strip():
        idx += 1
    if idx >= len(lines):
        raise InputError(path, "no column row", expected="a row of column names")
    header_idx = idx
    sep = _guess_sep(lines[header_idx])
    headers = split_cells(lines[header_idx], sep)
    rest = [ln for ln in lines[header_idx + 1 : header_idx + 40] if ln.strip()]
    decimal = _guess_decimal(sep, rest[1:] if len(rest) > 1 else rest)
    units_row = None
    data_idx = header_idx + 1
    if data_idx < len(lines) and lines[data_idx].strip():
        cells = split_cells(lines[data_idx], sep)
        if not any(c and is_number(c, decimal) for c in cells):
            units_row = cells
            data_idx += 1
    while data_idx < len(lines) and not lines[data_idx].strip():
        data_idx += 1
    if data_idx >= len(lines) or not lines[data_idx].strip():
        raise InputError(path, "no data rows", line=header_idx + 1,
                         expected="data under the header")
    n_data = len(split_cells(lines[data_idx], sep))
    if len(headers) == 1 < n_data:  # one field: a title line (extra fields are caught later)
        raise InputError(
            path, f"the column row (line {header_idx + 1}) has {len(headers)} field(s) but the "
            f"data rows have {n_data}: is line {header_idx + 1} a title or date line?",
            line=header_idx + 1,
            expected="skip_lines = N in the mapping file (the lines before the column row)",
        )
    samples = [split_cells(ln, sep) for ln in lines[data_idx:data_idx + 20] if ln.strip()]
    return CsvLayout(
        path=path, sep=sep, decimal=decimal, encoding=encoding, headers=headers,
        units_row=units_row, header_line=header_idx + 1, data_line=data_idx + 1,
        data_offset=offsets[data_idx], preamble=meta, samples=samples,
    )


def line_at(layout: CsvLayout, offset: int) -> int:
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
