"""Pass 2 over a session's samples: the scratch files of pass 1 (:mod:`bench.ingest.scan`)
back, the zero offset off, the analyzer power joined, each sample tagged with its
window, into the samples Parquet file row group by row group, and the windows' exact
statistics accumulated on the way."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from bench.ingest import align
from bench.ingest.analyzer import AlignedPower
from bench.ingest.drum_frame import fold_signed
from bench.ingest.scan import StreamScan
from bench.ingest.session import Session
from bench.ingest.store_tables import points_table
from bench.ingest.temperature import STORE_COLUMN
from bench.store.schema import SAMPLES_SCHEMA, TEMPERATURE_COLUMNS
from kernel.units import RPM_PER_RAD_S

#: samples per chunk in the second pass (about 80 bytes of arrays each) [-]
PASS2_ROWS = 500_000

#: Parquet writer options of the samples files: snappy, float columns byte-stream
#: split (their bytes grouped by significance before compression), min/max
#: statistics only where a reader filters (time, point). Against snappy with
#: plain encoding and statistics on every column this cuts the write CPU time by
#: about 40 % at 3 % more bytes (benchmarks/README.md)
SAMPLES_WRITE_OPTIONS = {
    "compression": "snappy",
    "use_dictionary": ["session_id"],
    "column_encoding": {
        name: "BYTE_STREAM_SPLIT"
        for name in ("time_s", "speed_rpm", "torque_nm", "p_mech_w", "p_elec_w")
    },
    "write_statistics": ["time_s", "point_id"],
}


def _point_ids(n: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Window index of each of ``n`` samples (``-1`` outside); window k is rows ``[lo_k, hi_k)``.

    Windows are disjoint and sorted, so a cumulative sum of +(k+1) at each start
    and -(k+1) at each end marks them.
    """
    marks = np.zeros(n + 1, np.int64)
    k = np.arange(lo.size) + 1
    np.add.at(marks, lo, k)
    np.add.at(marks, hi, -k)
    return (np.cumsum(marks[:-1]) - 1).astype(np.int32)


class WindowStats:
    """Exact per-window means and standard deviations from streamed samples.

    Windows are contiguous row ranges of the time-sorted samples, so one
    ``np.add.reduceat`` per quantity and chunk gives their sums and sums of
    squares. (Float64 keeps the variance to ~1e-6 relative even for 8 kW means
    with 10 W noise over 10^4 samples.)
    """

    Q = ("speed", "torque", "p_mech", "p_elec")

    def __init__(self, n: int) -> None:
        self.n = n
        self.count = np.zeros(n)
        self.s1 = {q: np.zeros(n) for q in self.Q}
        self.s2 = {q: np.zeros(n) for q in self.Q}
        #: temperature column -> (sum of valid values, their count) per window
        self.temps: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def add_temperature(self, lo, hi, name: str, x: np.ndarray) -> None:
        """Accumulate one chunk of a temperature column [degC] (its own valid samples)."""
        live = np.flatnonzero(hi > lo)
        if live.size == 0:
            return
        s, c = self.temps.setdefault(name, (np.zeros(self.n), np.zeros(self.n)))
        csum = np.concatenate(([0.0], np.cumsum(np.where(np.isfinite(x), x, 0.0))))
        ccnt = np.concatenate(([0], np.cumsum(np.isfinite(x))))
        s[live] += csum[hi[live]] - csum[lo[live]]
        c[live] += ccnt[hi[live]] - ccnt[lo[live]]

    def add(self, lo, hi, speed, torque, p_mech, p_elec) -> None:
        """Accumulate one chunk; window k covers its rows ``[lo_k, hi_k)``."""
        live = np.flatnonzero(hi > lo)
        if live.size == 0:
            return
        lo, hi = lo[live], hi[live]
        idx = np.empty(2 * lo.size, np.int64)
        idx[0::2], idx[1::2] = lo, hi
        if idx[-1] == speed.size:
            idx = idx[:-1]  # the last window runs to the end of the chunk

        def window_sums(x: np.ndarray) -> np.ndarray:
            return np.add.reduceat(x, idx)[0::2]

        ok = np.isfinite(speed) & np.isfinite(torque) & np.isfinite(p_elec)
        self.count[live] += window_sums(ok.astype(np.float64))
        for q, x in zip(self.Q, (speed, torque, p_mech, p_elec), strict=True):
            d = np.where(ok, x, 0.0)
            self.s1[q][live] += window_sums(d)
            self.s2[q][live] += window_sums(d * d)

    def points_table(self, session: Session, w_start, w_end) -> pa.Table:
        """The session's points: window means and sample standard deviations."""
        n = np.maximum(self.count, 1)
        cols = {}
        for q, name in zip(self.Q, ("speed_rpm", "torque_nm", "p_mech_w", "p_elec_w"),
                           strict=True):
            m = self.s1[q] / n
            var = np.maximum(self.s2[q] - n * m * m, 0.0) / np.maximum(n - 1, 1)
            cols[name] = m
            cols[name + "_std"] = np.sqrt(var)
        for name, (s, c) in self.temps.items():
            with np.errstate(invalid="ignore", divide="ignore"):
                cols[name] = np.where(c > 0, s / c, np.nan)
        return points_table(session, cols, np.rint(self.count).astype(np.int32), w_start, w_end,
                            "timeseries")


def write_samples(path: Path, session: Session, scan: StreamScan, offset_nm: float,
                  power: AlignedPower | None, w_start: np.ndarray, w_end: np.ndarray,
                  progress: Callable[[int], None], size_bytes: int) -> WindowStats:
    """Write the samples file from the scratch files (removed afterwards).

    Parameters
    ----------
    path : Path
        The samples Parquet file to write.
    session : Session
        Its metadata (id, signed torque).
    scan : StreamScan
        Pass 1: the scratch files and the row count.
    offset_nm : float
        The torque zero offset [N m].
    power : AlignedPower or None
        The analyzer's power on the DAQ clock; None for a single-stream log (its
        p_elec is in a scratch file).
    w_start, w_end : numpy.ndarray
        The accepted windows' bounds on the DAQ clock [s].
    progress : callable
        Called with the number of source bytes handled.
    size_bytes : int
        The stream's size [B] (for the progress).

    Returns
    -------
    WindowStats
        The windows' sums, for their points.
    """
    stats = WindowStats(len(w_start))
    rows, n_rows = PASS2_ROWS, scan.n_rows
    # the temperature channels that passed their checks (a flagged one is stored as NaN)
    temps = {q: STORE_COLUMN[q] for q, chk in scan.temps.items() if chk.note() is None}
    sid_dict = pa.array([session.session_id], pa.string())
    with pq.ParquetWriter(path, SAMPLES_SCHEMA, **SAMPLES_WRITE_OPTIONS) as writer:
        fhs = {q: open(p, "rb") for q, p in scan.spill.items()}
        try:
            done = 0
            while done < n_rows:
                t = np.fromfile(fhs["time"], np.float64, rows)
                speed = np.fromfile(fhs["speed"], np.float64, rows)
                torque = np.fromfile(fhs["torque"], np.float64, rows) - offset_nm
                if session.signed_torque:
                    speed, torque = fold_signed(speed, torque)
                p_mech = speed * torque / RPM_PER_RAD_S
                if power is None:
                    p_elec = np.fromfile(fhs["p_elec"], np.float64, rows)
                else:
                    p_elec = align.asof_nearest(t, power.t_s, power.p_w, 0.75 * power.interval_s)
                lo, hi = np.searchsorted(t, w_start), np.searchsorted(t, w_end)
                stats.add(lo, hi, speed, torque, p_mech, p_elec)
                temp_cols = {name: np.full(t.size, np.nan) for name in TEMPERATURE_COLUMNS}
                for q in scan.temps:  # read every spill in step; store the checked ones
                    x = np.fromfile(fhs[q], np.float64, rows)
                    if q in temps:
                        temp_cols[temps[q]] = x
                        stats.add_temperature(lo, hi, temps[q], x)
                writer.write_table(pa.Table.from_arrays([
                    pa.DictionaryArray.from_arrays(np.zeros(t.size, np.int32), sid_dict),
                    t, speed, torque, p_mech, p_elec, _point_ids(t.size, lo, hi),
                    *temp_cols.values(),
                ], schema=SAMPLES_SCHEMA))
                done += t.size
                progress(int(size_bytes * t.size / n_rows) // 2)
        finally:
            for h in fhs.values():
                h.close()
            for p in scan.spill.values():
                p.unlink(missing_ok=True)
    return stats
