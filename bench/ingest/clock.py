"""Clock-time columns: time of day and ISO 8601 date-times into seconds.

A logger may write its time axis as a number (seconds, ``ms``, ``us``: a unit,
handled by :mod:`column_units`) or as a clock reading:

- **time of day** ``hh:mm:ss`` with an optional fraction (``09:12:03.250``, or
  ``09:12:03,250`` in German locale) and an optional ``AM``/``PM`` (12-hour
  clock: ``12:00:05 AM`` is 00:00:05); the date is the session's ``date``; a
  step back by more than 12 hours is a midnight rollover (one day added);
- **ISO 8601 date-time** ``2013-04-17T09:12:03.250`` (``T`` or a space between
  date and time, optional fraction, optional ``Z`` or ``+hh:mm`` zone; with a
  zone the times are taken in UTC).

Either becomes seconds since the stream's first valid time (so the stream's own
clock starts at 0, as a numeric one does) and the wall time of that first
sample (``start``), which places the stream against another instrument.

A logger that stamps whole seconds while sampling faster (2-5 rows per ``09:12:03``)
repeats each stamp: the rows of one stamp are spread evenly over that second (row
``j`` of a stamp at ``+ j / n``, ``n`` the rows per stamp of the first chunk, at
most ``j / (j + 1)`` so the time stays inside the second) and ``spread_rows`` says
how many per stamp were found. When the first chunk's median is one row per stamp, a
repeated stamp is a duplicated row and stays an error. A stream whose mapping names a
sample counter (``sample_counter``, :mod:`mapping`) is not spread: the reader adds
counter / rate to each stamp.
"""

from __future__ import annotations

import re
from datetime import date, datetime, timedelta

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

#: the two clock formats, as the ``unit`` of a time column
TIME_OF_DAY = "hh:mm:ss"
DATETIME = "ISO 8601"
CLOCK_UNITS = (TIME_OF_DAY, DATETIME)

_TOD = re.compile(r"^\d{1,2}:\d{2}:\d{2}([.,]\d+)?(\s*[AaPp]\.?[Mm]\.?)?$")
_AMPM = re.compile(r"\s*([AaPp])\.?[Mm]\.?$")
_ISO = re.compile(r"^\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}([.,]\d+)?)?(Z|[+-]\d{2}:?\d{2})?$")
_ZONE = re.compile(r"(Z|[+-]\d{2}:?\d{2})$")

#: a time of day this far below the previous one is the next day [s]
ROLLOVER_S = 12 * 3600.0


def detect(cells: list[str]) -> str | None:
    """The clock format of a column's first data cells, or None when they are not clock times.

    Parameters
    ----------
    cells : list of str
        Cells of the column, first rows of the file (empty ones are skipped);
        at least 80 % of the others must be clock times of one format.
    """
    cells = [c.strip() for c in cells if c.strip()]
    if not cells:
        return None
    for unit, pattern in ((TIME_OF_DAY, _TOD), (DATETIME, _ISO)):
        # most of them: a damaged cell is then reported with its line when parsed
        if sum(bool(pattern.match(c)) for c in cells) >= 0.8 * len(cells):
            return unit
    return None


def normalise_unit(unit: str) -> str | None:
    """The clock format a written unit names (``hh:mm:ss``, ``hh:mm:ss.sss``, ``ISO 8601``), or
    None."""
    u = re.sub(r"\s+", "", unit).lower()
    if re.fullmatch(r"hh:mm:ss([.,]s+|[.,]f+)?", u):
        return TIME_OF_DAY
    if u in ("iso8601", "iso", "datetime"):
        return DATETIME
    return None


class ClockParser:
    """Turn chunks of clock-time strings into seconds since the first valid time.

    Parameters
    ----------
    unit : str
        :data:`TIME_OF_DAY` or :data:`DATETIME`.
    day : datetime.date or None
        The date of a time-of-day column (the session's ``date``); None leaves
        ``start`` without a date (1900-01-01).
    spread : bool
        Spread the rows of repeated whole-second stamps within their second (off
        when a sample counter places them).

    Attributes
    ----------
    start : datetime or None
        Wall time of the first valid sample (time 0), once seen.
    """

    def __init__(self, unit: str, day: date | None = None, spread: bool = True) -> None:
        self.unit = unit
        self.day = day
        self.spread = spread
        self.start: datetime | None = None
        self._base: float | None = None  # first valid raw value [s]
        self._days = 0  # midnight rollovers so far
        self._last = np.nan  # last valid raw value [s]
        self.spread_rows: int | None = None  # rows per repeated whole-second stamp
        self._run = 0  # rows of the current stamp seen so far

    def __call__(self, cells: pa.Array) -> np.ndarray:
        """Seconds [s] for one chunk of strings (null = invalid -> NaN).

        Raises
        ------
        ValueError
            A cell that is not a clock time of the format (the caller names its line).
        """
        if self.unit == TIME_OF_DAY:
            raw = self._seconds_of_day(cells)
        else:
            raw = self._epoch_seconds(cells)
        ok = np.flatnonzero(np.isfinite(raw))
        if ok.size == 0:
            return raw
        if self._base is None:
            self._base = float(raw[ok[0]])
            self.start = self._wall(self._base)
        v = raw[ok]
        if self.unit == TIME_OF_DAY:
            back = np.diff(v, prepend=self._last) < -ROLLOVER_S
            days = self._days + np.cumsum(back)
            v = v + 86400.0 * days
            self._days = int(days[-1])
        raw[ok] = self._spread(v) if self.spread else v
        if not self.spread:
            self._last = float(v[-1])
        return raw - self._base

    def _spread(self, v: np.ndarray) -> np.ndarray:
        """Spread the rows of repeated whole-second stamps evenly within their second."""
        last, self._last = self._last, float(v[-1])
        if not np.all(v == np.floor(v)):
            return v  # stamps with a fraction: repeats stay an error (the caller's check)
        new = np.diff(v, prepend=last) != 0  # first row of each stamp
        if self.spread_rows is None:
            starts = np.flatnonzero(new)
            if starts.size == v.size and np.isfinite(last):
                return v  # one row per stamp: nothing to spread
            runs = np.diff(np.concatenate((starts, [v.size])))
            if runs.size == 0 or np.median(runs) < 2:
                return v  # a repeat here and there is a duplicated row: the caller's error
            self.spread_rows = int(np.median(runs))
        idx = np.arange(v.size)
        first = np.maximum.accumulate(np.where(new, idx, -1))
        j = np.where(first >= 0, idx - first, idx + self._run)  # row within its stamp
        self._run = int(j[-1]) + 1
        n = max(self.spread_rows or 1, 1)
        return v + j / np.maximum(n, j + 1.0)

    def _seconds_of_day(self, cells: pa.Array) -> np.ndarray:
        text = pc.replace_substring(pc.utf8_trim_whitespace(cells), ",", ".")
        half = pc.extract_regex(text, r"(?P<ap>[AaPp])\.?[Mm]\.?$")
        pm = None
        if pc.any(pc.is_valid(half)).as_py():  # a 12-hour clock: 12 AM is 0 h, 1-11 PM + 12 h
            ap = pc.utf8_lower(pc.struct_field(half, [0])).to_numpy(zero_copy_only=False)
            pm = np.array([a == "p" if a is not None else None for a in ap], dtype=object)
            text = pc.utf8_trim_whitespace(pc.replace_substring_regex(
                text, r"\s*[AaPp]\.?[Mm]\.?$", ""))
        parts = pc.split_pattern(text, ":")
        n = pc.list_value_length(parts).to_numpy(zero_copy_only=False)
        if np.any((n != 3) & np.isfinite(n.astype(float))):
            raise ValueError(f"not a time of day {TIME_OF_DAY}[.fff]")
        h, m, s = (pc.cast(pc.list_element(parts, i), pa.float64()).to_numpy(zero_copy_only=False)
                   for i in range(3))
        if np.any((h > 47) | (m >= 60) | (s >= 61)):  # 24:00:00 and leap seconds pass
            raise ValueError(f"not a time of day {TIME_OF_DAY}[.fff]")
        if pm is not None:
            mixed = np.array([p is None for p in pm]) & np.isfinite(h)
            if np.any(mixed) or np.any((h < 1) | (h > 12)):
                raise ValueError(f"not a time of day {TIME_OF_DAY}[.fff] [AM|PM]: a 12-hour "
                                 "time needs AM or PM on every row and hours 1 to 12")
            h = np.where(h == 12, 0.0, h) + np.where(pm.astype(bool), 12.0, 0.0)
        return h * 3600.0 + m * 60.0 + s

    def _epoch_seconds(self, cells: pa.Array) -> np.ndarray:
        text = pc.replace_substring(pc.utf8_trim_whitespace(cells), ",", ".")
        first = next((c for c in text.to_pylist() if c), "")
        zoned = bool(_ZONE.search(first)) and not first.endswith(("-", "+"))
        ts = pc.cast(text, pa.timestamp("us", tz="UTC" if zoned else None))
        us = ts.cast(pa.int64()).to_numpy(zero_copy_only=False)
        out = np.asarray(us, dtype=np.float64) * 1e-6
        if ts.null_count:
            out[np.asarray(ts.is_null())] = np.nan
        return out

    def _wall(self, raw_s: float) -> datetime:
        if self.unit == TIME_OF_DAY:
            return datetime.combine(self.day or date(1900, 1, 1), datetime.min.time()) + \
                timedelta(seconds=raw_s)
        return datetime(1970, 1, 1) + timedelta(seconds=raw_s)
