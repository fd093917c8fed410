"""Invalid-value markers, and the checks that run on every streamed chunk.

Instruments write ``9.91E+37`` (Yokogawa/Keysight overflow), ``NAN``, ``INF``,
``---`` or an empty cell for a sample they could not measure. Isolated markers
become NaN and are skipped when averaging; a run longer than
:data:`MAX_NAN_RUN` consecutive samples in one column is an error, because it
means a sensor or channel was lost rather than a sample.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from kernel.errors import InputError

#: cell texts read as "no value" (matched exactly by the CSV parser)
NULL_MARKERS: tuple[str, ...] = (
    "", "NAN", "NaN", "nan", "-NAN", "-nan", "INF", "+INF", "-INF", "Inf", "-Inf",
    "inf", "-inf", "---", "--", "-", "#N/A", "N/A",
)

#: numbers this large are overflow markers (9.91E+37, 9.9E37), never measurements
MARKER_ABS = 1e30

#: longest tolerated run of consecutive invalid samples in one column [samples]
MAX_NAN_RUN = 25


def scrub(values: np.ndarray) -> np.ndarray:
    """Float64 ``values`` with overflow markers and infinities as NaN (copied only if any)."""
    out = np.asarray(values, dtype=np.float64)
    bad = np.abs(out) > MARKER_ABS  # inf > 1e30 too; NaN stays NaN
    if bad.any():
        out = out.copy()
        out[bad] = np.nan
    return out


class NanRunCheck:
    """Track runs of NaN in one column across chunks; raise on a run too long.

    Parameters
    ----------
    path : Path
        File being read (for the error).
    column : str
        Column header (for the error).
    line_of_row : callable
        ``row -> 1-based line`` (or None when the format has no lines).
    max_run : int
        Longest tolerated run [samples].
    """

    def __init__(self, path, column: str, line_of_row: Callable[[int], int | None],
                 max_run: int = MAX_NAN_RUN) -> None:
        self.path, self.column, self.line_of_row, self.max_run = path, column, line_of_row, max_run
        self.open_start = 0  # first row of the run still open at the end of the last chunk
        self.open_len = 0  # its length so far [samples]

    def feed(self, values: np.ndarray, row0: int) -> None:
        """Check one chunk whose first row has 0-based index ``row0``."""
        isnan = np.isnan(values)
        if not isnan.any():  # fast path: close an open run, nothing else to do
            if self.open_len > self.max_run:
                self._raise(self.open_start, self.open_len)
            self.open_len = 0
            return
        edges = np.diff(np.concatenate(([0], isnan.view(np.int8), [0])))
        starts = np.flatnonzero(edges == 1).tolist()
        ends = np.flatnonzero(edges == -1).tolist()  # exclusive
        runs = [(row0 + s, e - s) for s, e in zip(starts, ends, strict=True)]
        if self.open_len:
            if runs and starts[0] == 0:
                runs[0] = (self.open_start, self.open_len + runs[0][1])
            else:
                runs.insert(0, (self.open_start, self.open_len))
        self.open_len = 0
        if runs and (not ends or ends[-1] == len(values)) and len(values) and isnan[-1]:
            self.open_start, self.open_len = runs.pop()
        for start, length in runs:
            if length > self.max_run:
                self._raise(start, length)

    def finish(self) -> None:
        """Check a run still open at the end of the file."""
        if self.open_len > self.max_run:
            self._raise(self.open_start, self.open_len)

    def _raise(self, start_row: int, length: int) -> None:
        raise InputError(
            self.path, f"run of {length} consecutive invalid values (NaN or markers)",
            line=self.line_of_row(start_row), column=self.column,
            expected=f"at most {self.max_run} consecutive invalid samples",
        )


class TimeCheck:
    """Check that time strictly increases across chunks (NaN times are skipped).

    Parameters
    ----------
    path : Path
        File being read.
    column : str
        Time column header.
    line_of_row : callable
        ``row -> 1-based line`` (or None).
    grid_s : float, optional
        Step of the time grid the caller bins the samples on [s]. Then the time
        span may not need more than ``GRID_PER_ROW`` grid steps per row plus
        ``GRID_SLACK`` (a pause in the recording): a single wrong time value (1e9 s)
        is named at its line instead of sizing a grid of billions of steps.
    """

    GRID_PER_ROW = 10
    GRID_SLACK = 1_000_000

    def __init__(self, path, column: str, line_of_row: Callable[[int], int | None],
                 grid_s: float | None = None) -> None:
        self.path, self.column, self.line_of_row = path, column, line_of_row
        self.last: float = -np.inf
        self.grid_s = grid_s
        self.first: float | None = None
        self.rows = 0

    def feed(self, time_s: np.ndarray, row0: int) -> None:
        """Check one chunk of times [s] whose first row has 0-based index ``row0``."""
        nan = np.isnan(time_s)
        ok = np.flatnonzero(~nan) if nan.any() else None
        t = time_s if ok is None else time_s[ok]
        if t.size == 0:
            return
        bad = np.flatnonzero(np.diff(t) <= 0) + 1
        if t[0] <= self.last:
            bad = np.concatenate(([0], bad))
        if bad.size:
            k = int(bad[0])
            prev = self.last if k == 0 else float(t[k - 1])
            what = "repeats" if t[k] == prev else "goes backwards"
            raise InputError(
                self.path, f"time {what}: {float(t[k]):.9g} s after {prev:.9g} s",
                line=self.line_of_row(row0 + (k if ok is None else int(ok[k]))),
                column=self.column,
                expected="strictly increasing time (a time of day hh:mm:ss stamped in whole "
                "seconds at 2 or more rows per second is spread evenly within each second)",
            )
        if self.grid_s is not None:
            self._check_span(t, row0, ok)
        self.last = float(t[-1])

    def _check_span(self, t: np.ndarray, row0: int, ok: np.ndarray | None) -> None:
        if self.first is None:
            self.first = float(t[0])
        self.rows += t.size
        span = float(t[-1]) - self.first
        if span / self.grid_s <= self.GRID_PER_ROW * self.rows + self.GRID_SLACK:
            return
        steps = np.diff(t, prepend=self.last if np.isfinite(self.last) else t[0])
        k = int(np.argmax(steps))
        prev = float(t[k] - steps[k])
        raise InputError(
            self.path, f"time jumps from {prev:.9g} s to {float(t[k]):.9g} s: "
            f"{span:.4g} s for {self.rows} rows is no single recording (a wrong time value?)",
            line=self.line_of_row(row0 + (k if ok is None else int(ok[k]))),
            column=self.column,
            expected=f"at most {self.GRID_PER_ROW * self.grid_s:g} s per row on average "
                     f"plus {self.GRID_SLACK * self.grid_s:g} s of pauses",
        )
