"""One timeseries session: DAQ stream + analyzer -> aligned samples, points, rejections.

Two passes over the DAQ so memory does not grow with the file:

1. Stream the DAQ file in chunks: check time and NaN runs, map into the drum
   frame, spill time/speed/torque to raw float64 scratch files, and accumulate
   0.1 s bin sums, and collect the leading standstill (:mod:`tare`). Subtract
   the flange zero offset the tare gives from the bin means, align the analyzer
   on the bins (:mod:`align`), check the torque sign, detect steady windows
   (:mod:`steady`) after the tare.
2. Stream the scratch files back: subtract the zero offset, as-of join the
   analyzer power, tag samples with their window, accumulate exact window
   statistics, and write the samples Parquet file row group by row group.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from bench.ingest import align, checks, steady, tare
from bench.ingest.checks import check_torque_sign
from bench.ingest.clock import TIME_OF_DAY
from bench.ingest.mapping import Mapping
from bench.ingest.readers import (
    CHUNK_BYTES,
    DaqStream,
    open_daq_csv,
    open_daq_tdms,
    read_analyzer,
)
from bench.ingest.scrub import NanRunCheck, TimeCheck
from bench.ingest.session import Session
from bench.store.schema import POINTS_SCHEMA, REJECTED_SCHEMA, SAMPLES_SCHEMA
from kernel.errors import InputError
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

#: smallest |correlation| of analyzer and DAQ power steps that counts as aligned [-]
MIN_ALIGN_CORRELATION = 0.3


@dataclass
class SessionOutput:
    """What a processed session hands to the store.

    Parameters
    ----------
    points : pyarrow.Table
        Operating points (store points schema).
    rejected : pyarrow.Table
        Rejected windows.
    samples_path : Path or None
        Staged samples Parquet file (timeseries sessions).
    info : dict
        Manifest fields: clock offset/drift, instruments, counts.
    """

    points: pa.Table
    rejected: pa.Table
    samples_path: Path | None
    info: dict


class _Bins:
    """Growing per-bin sums on a grid ``t0 + k * dt`` (time sorted, so bins are runs).

    The bin width and the gap threshold follow the stream's median sample
    interval, taken from its first chunk (:func:`steady.bin_width_s`,
    :func:`steady.gap_threshold_s`); the grid starts half a sample interval
    before the first sample, so a regular logger puts its samples mid-bin.
    Gaps are kept as bin ranges ``[first empty bin, first bin after the gap]``.

    Parameters
    ----------
    config : SteadyConfig
        Gives the narrowest bin and the gap factor.
    extra : tuple of str
        Further per-sample quantities whose bin means are wanted (``p_elec``,
        ``p_mech_logged`` of a single-stream log); each has its own valid count.
        Their bin means come out under the same names.
    """

    BASE = ("rows", "valid", "speed", "torque")

    def __init__(self, config: steady.SteadyConfig, extra: tuple[str, ...] = ()) -> None:
        self.config = config
        self.extra = extra
        self.fields = self.BASE + extra + tuple(f"{q}_n" for q in extra)
        self.dt = config.bin_s
        self.interval_s = math.nan
        self.gap_s = math.inf
        self.t0: float | None = None
        self.last_t = math.nan
        self.gaps: list[np.ndarray] = []
        self.sums = {f: np.zeros(0) for f in self.fields}

    def _start(self, t: np.ndarray) -> None:
        d = np.diff(t[:100_000])
        self.interval_s = float(np.median(d)) if d.size else math.nan
        self.dt = steady.bin_width_s(self.interval_s, self.config)
        if d.size:
            self.gap_s = steady.gap_threshold_s(self.interval_s, self.config)
        half = 0.5 * min(self.dt, self.interval_s) if d.size else 0.0
        self.t0 = float(t[0]) - half

    def add(self, t: np.ndarray, speed: np.ndarray, torque: np.ndarray, **extra) -> None:
        """Add a chunk of sorted times [s] and drum-frame speed [rpm] and torque [N m]
        (and the ``extra`` quantities by name)."""
        if self.t0 is None:
            self._start(t)
        k = ((t - self.t0) / self.dt).astype(np.int64)
        jumps = np.flatnonzero(np.diff(t, prepend=self.last_t) > self.gap_s)
        if jumps.size:
            after = k[jumps]
            before = k[np.maximum(jumps - 1, 0)]
            if jumps[0] == 0:  # the gap lies between the last chunk and this one
                before[0] = int((self.last_t - self.t0) / self.dt)
            self.gaps.append(np.column_stack((before + 1, after)))
        self.last_t = float(t[-1])
        starts = np.concatenate(([0], np.flatnonzero(np.diff(k)) + 1))
        ids = k[starts]
        n = int(ids[-1]) + 1
        if n > self.sums["rows"].size:
            size = max(n, self.sums["rows"].size + self.sums["rows"].size // 4)
            for f in self.fields:
                grown = np.zeros(size)
                grown[: self.sums[f].size] = self.sums[f]
                self.sums[f] = grown
        ok = np.isfinite(speed) & np.isfinite(torque)
        self.sums["rows"][ids] += np.diff(np.append(starts, t.size))
        self.sums["valid"][ids] += np.add.reduceat(ok, starts, dtype=np.int64)
        for f, x in (("speed", speed), ("torque", torque)):
            self.sums[f][ids] += np.add.reduceat(np.where(ok, x, 0.0), starts)
        for f in self.extra:
            x = extra[f]
            fin = np.isfinite(x)
            self.sums[f][ids] += np.add.reduceat(np.where(fin, x, 0.0), starts)
            self.sums[f + "_n"][ids] += np.add.reduceat(fin, starts, dtype=np.int64)

    def means(self, n_bins: int, torque_offset_nm: float = 0.0) -> dict[str, np.ndarray]:
        """Bin means of speed and torque (less ``torque_offset_nm``), their product as
        ``p_mech`` [W], the extra quantities, the valid fraction (NaN for empty bins)
        and ``cuts`` (True for the bins of a gap and the first bin after it; a
        gap is a hole in the time axis or a run of bins without a valid sample,
        each longer than the gap threshold)."""
        valid = self.sums["valid"][:n_bins]
        rows = self.sums["rows"][:n_bins]
        with np.errstate(invalid="ignore", divide="ignore"):
            out = {f: self.sums[f][:n_bins] / valid for f in ("speed", "torque")}
            out["torque"] = out["torque"] - torque_offset_nm
            out["valid_frac"] = np.where(rows > 0, valid / rows, np.nan)
            for f in self.extra:
                out[f] = self.sums[f][:n_bins] / self.sums[f + "_n"][:n_bins]
        # product of bin means: enough for the alignment; points use exact sample means
        out["p_mech"] = out["speed"] * out["torque"] / RPM_PER_RAD_S
        # runs of bins without a valid sample longer than the gap threshold are gaps too
        edges = np.diff(np.concatenate(([0], (valid == 0).astype(np.int8), [0])))
        r0, r1 = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        long = (r1 - r0) * self.dt > self.gap_s
        marks = np.zeros(n_bins + 1, np.int64)
        for g in [*self.gaps, np.column_stack((r0[long], r1[long]))]:
            np.add.at(marks, np.minimum(g[:, 0], n_bins), 1)
            np.add.at(marks, np.minimum(g[:, 1] + 1, n_bins), -1)
        out["cuts"] = np.cumsum(marks[:-1]) > 0
        return out

    @property
    def n_gaps(self) -> int:
        """Gaps found so far."""
        return sum(g.shape[0] for g in self.gaps)


def open_stream(session: Session, mapping: Mapping, chunk_bytes: int) -> DaqStream:
    """Open the DAQ stream (``[daq]``, CSV or TDMS) or single-stream log (``[log]``, CSV) a
    session names."""
    name = "log" if session.single_stream else "daq"
    table = session.table(name)
    path = session.file(name)
    fmt = table.get("format", "csv")
    if fmt == "csv":
        if name == "log":
            mapped = mapping.section("log")
            return open_daq_csv(path, mapping, chunk_bytes, day=session.day(), section="log",
                                required=("time", "speed", "torque", "p_elec"),
                                optional=("p_mech",) if "p_mech" in mapped else ())
        return open_daq_csv(path, mapping, chunk_bytes, day=session.day())
    if fmt == "tdms" and name == "daq":
        return open_daq_tdms(path, str(table.get("tdms_group", "Measurement")), mapping)
    raise InputError(session.path, f"unknown [{name}] format {fmt!r}", column=f"{name}.format",
                     expected="'csv' or 'tdms'" if name == "daq" else "'csv'")


def _drum_frame(session: Session, speed, torque):
    """Logged speed and torque to the drum shaft (signs, gear); a signed torque is folded
    later (:func:`fold_signed`), after the zero offset is off."""
    speed = speed * session.speed_sign
    torque = torque * session.torque_sign
    if session.measured_side == "motor":
        speed = speed / session.gear_ratio
        torque = torque * session.gear_ratio
    return speed, torque


def _drum_ranges(session: Session) -> dict[str, float]:
    """Sensor ranges [rpm, N m, W] seen from the drum (ranges are of the measured shaft)."""
    r = dict(session.ranges)
    if session.measured_side == "motor":
        r["speed"] /= session.gear_ratio
        r["torque"] *= session.gear_ratio
    return r


def _disk_full(path: Path, why: str) -> None:
    raise InputError(path.parent, f"cannot write the session's samples into the store "
                     f"({why}): the disk is probably full", expected="free space for the store")


def _spill(arr: np.ndarray, handle, path: Path) -> None:
    """Append ``arr`` to a scratch file of the store; a full disk names the store."""
    try:
        arr.tofile(handle)
    except OSError as exc:  # numpy says "N requested and M written", without an errno
        _disk_full(path, exc.strerror or str(exc))


#: a DAQ sample whose |speed x torque| exceeds this many times the 90th percentile of
#: the binned |P_mech| is a spike (a few such samples dominate a bin's mean)
SPIKE_FACTOR = 1000.0


class _PeakSample:
    """The DAQ row of the largest |speed x torque|, to tell a spike from a bad analyzer."""

    def __init__(self) -> None:
        self.value, self.row, self.speed, self.torque = -1.0, -1, math.nan, math.nan

    def feed(self, speed: np.ndarray, torque: np.ndarray, row0: int) -> None:
        """Take one chunk of drum-frame speed [rpm] and torque [N m], first row ``row0``."""
        with np.errstate(over="ignore", invalid="ignore"):
            p = np.abs(speed * torque)
        if p.size and np.isfinite(p).any():
            k = int(np.nanargmax(np.where(np.isfinite(p), p, -1.0)))
            if p[k] > self.value:
                self.value, self.row = float(p[k]), row0 + k
                self.speed, self.torque = float(speed[k]), float(torque[k])

    def check(self, daq, p_mech_bins: np.ndarray) -> None:
        """Raise InputError naming the DAQ file and line when the peak is a spike."""
        typical = np.nanpercentile(np.abs(p_mech_bins), 90) if np.isfinite(
            p_mech_bins).any() else 0.0
        p_mech = self.value * math.pi / 30.0  # rpm x N m -> W
        if typical > 0 and p_mech > SPIKE_FACTOR * typical:
            col = daq.metadata["columns"]["torque"]["column"]
            raise InputError(daq.path, f"a DAQ sample of {self.torque:.4g} N m at "
                             f"{self.speed:.4g} rpm ({p_mech:.3g} W) is {p_mech / typical:.3g} "
                             "times the typical speed x torque: a spike that also keeps the "
                             "analyzer from being aligned", line=daq.line_of_row(self.row),
                             column=col, expected="plausible torque and speed samples")


def process_timeseries(
    session: Session,
    mapping: Mapping,
    scratch: Path,
    config: steady.SteadyConfig = steady.DEFAULT_STEADY,
    chunk_bytes: int = CHUNK_BYTES,
    progress: Callable[[int], None] = lambda n: None,
) -> SessionOutput:
    """Read, align and average one timeseries session; stage its samples file.

    A session is either a DAQ stream plus a power-analyzer record on another
    clock (``[daq]`` + ``[analyzer]``: aligned here), or one single-stream log
    (``[log]``) holding time, speed, torque and p_elec on one clock.

    Parameters
    ----------
    session : Session
        Its metadata.
    mapping : Mapping
        Column mapping for foreign names (may be empty).
    scratch : Path
        A staging directory for scratch and output files.
    config : SteadyConfig
        Steady-state detection settings (``bin_s`` is the narrowest bin: a
        slower logger gets bins of its sample interval).
    chunk_bytes : int
        CSV bytes per chunk [B].
    progress : callable
        Called with the number of source bytes handled.

    Returns
    -------
    SessionOutput
    """
    sid = session.session_id
    single = session.single_stream
    daq = open_stream(session, mapping, chunk_bytes)
    if daq.clock is not None and daq.clock.unit == TIME_OF_DAY and session.day() is None:
        raise InputError(session.path, f"{daq.path.name} gives the time of day only, and "
                         "session.toml has no date", column="date",
                         expected='date = "YYYY-MM-DD", the day the log starts')
    sources = checks.sources_from_meta(daq.path, daq.metadata["columns"])
    if not single:
        apath = session.file("analyzer")
        analyzer, ameta = read_analyzer(apath, mapping, day=session.day())
        alayout = ameta.pop("layout")
        _check_analyzer(apath, analyzer, ameta, alayout)
        sources.update(checks.sources_from_meta(apath, ameta["columns"]))
        checks.check_signal(sources["p_elec"], "p_elec", analyzer["p_elec_w"].to_numpy(), True)
    # per-sample quantities besides time, speed, torque
    extra = tuple(q for q in ("p_elec", "p_mech") if q in daq.metadata["columns"])
    bin_names = {q: "p_mech_logged" if q == "p_mech" else q for q in extra}

    # pass 1
    bins = _Bins(config, extra=tuple(bin_names.values()))
    cols = daq.metadata["columns"]
    tcheck = TimeCheck(daq.path, cols["time"]["column"], daq.line_of_row, config.bin_s)
    nan_checks = {q: NanRunCheck(daq.path, cols[q]["column"], daq.line_of_row)
                  for q in ("time", "speed", "torque") + extra}
    ranges = _drum_ranges(session)
    tare_finder = tare.TareFinder(ranges["speed"], ranges["torque"])
    spill = {q: scratch / f"{sid}.{q}.f64"
             for q in ("time", "speed", "torque") + (("p_elec",) if single else ())}
    handles = {q: open(p, "wb") for q, p in spill.items()}
    peak = _PeakSample()
    spilled = dict.fromkeys(handles, 0)
    n_rows = n_total = 0
    try:
        for chunk in daq.chunks():
            v = chunk.values
            for q, chk in nan_checks.items():
                chk.feed(v[q], chunk.row0)
            tcheck.feed(v["time"], chunk.row0)
            t = v["time"]
            speed, torque = _drum_frame(session, v["speed"], v["torque"])
            peak.feed(speed, torque, chunk.row0)
            more = {q: v[q] for q in extra}
            if "p_mech" in more:  # logged in the bench's frame: to the drum frame's sign
                more["p_mech"] = more["p_mech"] * (session.speed_sign * session.torque_sign)
            n_total += t.size
            keep = np.isfinite(t)
            if not keep.all():
                t, speed, torque = t[keep], speed[keep], torque[keep]
                more = {q: x[keep] for q, x in more.items()}
            if t.size:
                tare_finder.feed(t, speed, torque)
                bins.add(t, speed, torque, **{bin_names[q]: x for q, x in more.items()})
                for q, arr in (("time", t), ("speed", speed), ("torque", torque), *more.items()):
                    if q in handles:
                        _spill(arr, handles[q], spill[q])
                        spilled[q] += arr.nbytes
                n_rows += t.size
            progress(chunk.nbytes // 2)
        for chk in nan_checks.values():
            chk.finish()
    finally:
        for h in handles.values():
            h.close()
    for q, n in spilled.items():  # a full disk can fail a buffered write without a word
        if spill[q].stat().st_size != n:
            _disk_full(spill[q], f"{spill[q].stat().st_size} of {n} bytes written")
    if n_rows == 0:
        raise InputError(daq.path, "no data rows", expected="DAQ samples")

    n_bins = int(np.flatnonzero(bins.sums["rows"])[-1]) + 1
    if n_bins * config.bin_s < config.min_window_s:  # nothing to align or average
        raise InputError(daq.path, f"only {n_rows} data row(s), {n_bins * config.bin_s:g} s "
                         "of recording", expected=f"a recording longer than the shortest "
                         f"steady window ({config.min_window_s:g} s)")
    zero, no_tare_why = tare_finder.result()
    offset = zero.offset_nm if zero is not None else 0.0
    means = bins.means(n_bins, offset)
    t0, dt = bins.t0, bins.dt
    config = replace(config, bin_s=dt)
    timing = {"sample_interval_s": round(bins.interval_s, 9), "bin_s": round(dt, 9),
              "gap_threshold_s": round(bins.gap_s, 9) if math.isfinite(bins.gap_s) else None,
              "n_gaps": bins.n_gaps, "duration_s": round(bins.last_t - t0, 6)}
    del bins  # the means are all later steps need
    centres = t0 + (np.arange(n_bins) + 0.5) * dt

    if single:
        clock = None
        p_elec_bins = means["p_elec"]
        checks.check_signal(sources["p_elec"], "p_elec", p_elec_bins, True)
        usable = np.ones(n_bins, bool)
    else:
        prior = _prior_offset(session, ameta, daq)
        # a power analyzer's record is the mean over the update interval that ends at its
        # time stamp: it stands for the middle of that interval
        interval = float(np.median(np.diff(analyzer["time_s"].to_numpy())))
        a_mid = analyzer["time_s"].to_numpy() - 0.5 * interval
        a_p = analyzer["p_elec_w"].to_numpy()
        del analyzer
        clock = align.estimate_clock(centres, means["p_mech"], a_mid, a_p, prior)
        if abs(clock.correlation) < MIN_ALIGN_CORRELATION:
            peak.check(daq, means["p_mech"])  # a DAQ spike, not the analyzer, may be at fault
            raise InputError(
                apath, "analyzer power does not follow the DAQ's speed x torque (peak "
                f"correlation {clock.correlation:.2f} within {align.MAX_LAG_S:g} s of the header "
                "start times)", expected="the power-analyzer record of the same bench run as "
                f"{daq.path.name}, overlapping it in time",
            )
        a_t = clock.to_daq(a_mid)
        del a_mid
        fin = np.flatnonzero(np.isfinite(a_p))
        p_elec_bins = np.interp(centres, a_t[fin], a_p[fin], left=np.nan, right=np.nan)
        usable = recorded_bins(centres, a_t[fin], interval * config.gap_factor)
        del fin
    check_torque_sign(session, means["p_mech"], p_elec_bins, daq.path)
    del centres
    recorded = usable
    # the tare is no window
    after_tare = (t0 + np.arange(n_bins) * dt >= zero.t_motion_s if zero is not None
                  else np.ones(n_bins, bool))
    usable = recorded & after_tare
    win = steady.find_windows(means["speed"], means["torque"], p_elec_bins, means["valid_frac"],
                              ranges, config, usable=usable, cuts=means["cuts"])
    win = _screen_windows(win, means, p_elec_bins, sources, session, daq.path,
                          tare_finder.limit_rpm)
    if not recorded.all():  # held setpoints the analyzer did not record: rejected, said
        gap = means["cuts"] & ~(means["valid_frac"] > 0)
        holds = steady.held_runs({"speed": means["speed"], "torque": means["torque"]},
                                 ~recorded & after_tare & ~gap, gap, win.tolerances, config,
                                 points=win.accepted)
        win = replace(win, rejected=sorted(win.rejected + [
            (a, b, "no analyzer samples") for a, b in holds]))
    unlogged = [] if single else _unlogged_holds(
        a_t, a_p, interval, t0, dt, means["cuts"] & ~(means["valid_frac"] > 0), win, config)
    w_start = np.array([t0 + a * dt for a, _ in win.accepted])
    w_end = np.array([t0 + b * dt for _, b in win.accepted])

    # pass 2
    samples_path = scratch / f"{sid}.samples.parquet"
    stats = _WindowStats(len(win.accepted))
    rows_per_chunk = PASS2_ROWS
    sid_dict = pa.array([sid], pa.string())
    with pq.ParquetWriter(samples_path, SAMPLES_SCHEMA, **SAMPLES_WRITE_OPTIONS) as writer:
        fhs = {q: open(p, "rb") for q, p in spill.items()}
        try:
            done = 0
            while done < n_rows:
                t = np.fromfile(fhs["time"], np.float64, rows_per_chunk)
                speed = np.fromfile(fhs["speed"], np.float64, rows_per_chunk)
                torque = np.fromfile(fhs["torque"], np.float64, rows_per_chunk) - offset
                if session.signed_torque:
                    speed, torque = fold_signed(speed, torque)
                p_mech = speed * torque / RPM_PER_RAD_S
                if single:
                    p_elec = np.fromfile(fhs["p_elec"], np.float64, rows_per_chunk)
                else:
                    p_elec = align.asof_nearest(t, a_t, a_p, 0.75 * interval)
                lo, hi = np.searchsorted(t, w_start), np.searchsorted(t, w_end)
                pid = _point_ids(t.size, lo, hi)
                stats.add(lo, hi, speed, torque, p_mech, p_elec)
                table = pa.Table.from_arrays([
                    pa.DictionaryArray.from_arrays(np.zeros(t.size, np.int32), sid_dict),
                    t, speed, torque, p_mech, p_elec, pid,
                ], schema=SAMPLES_SCHEMA)
                writer.write_table(table)
                done += t.size
                progress(int(daq.size_bytes * t.size / n_rows) // 2)
        finally:
            for h in fhs.values():
                h.close()
            for p in spill.values():
                p.unlink(missing_ok=True)

    points = stats.points_table(session, w_start, w_end)
    if not session.signed_torque:
        check_drum_torque(session, points.column("torque_nm").to_numpy(),
                          win.tolerances["torque"], daq.path)
    rejected = rejected_table(sid, sorted(
        [(t0 + a * dt, t0 + b * dt, r) for a, b, r in win.rejected] + unlogged))
    instruments = {"log": daq.metadata} if single else {"daq": daq.metadata, "analyzer": ameta}
    info = {
        "clock_offset_s": None if clock is None else round(clock.offset_s, 6),
        "clock_drift_ppm": None if clock is None else round(clock.drift_ppm, 3),
        **({} if clock is None or not np.isfinite(clock.drift_estimate_ppm) else {
            "clock_drift_estimate_ppm": round(clock.drift_estimate_ppm, 3),
            "clock_drift_uncertainty_ppm": round(clock.drift_uncertainty_ppm, 3)}),
        **({} if clock is None or clock.drift_note is None else
           {"clock_drift_note": clock.drift_note}),
        "clock_offset_prior_s": None if clock is None else round(clock.prior_offset_s, 6),
        "clock_correlation": None if clock is None else round(clock.correlation, 4),
        "torque_zero_offset_nm": None if zero is None else round(zero.offset_nm, 6),
        "torque_zero_tare": None if zero is None else zero.manifest(),
        **({} if zero is not None else {"torque_zero_note": no_tare_why}),
        "n_samples": int(n_rows),
        "n_rows_without_time": int(n_total - n_rows),
        "steady_tolerances": {k: round(v, 6) for k, v in win.tolerances.items()},
        "timing": timing,
        "instruments": instruments,
    }
    if daq.clock is not None and daq.clock.start is not None:
        info["start"] = daq.clock.start.isoformat()
    if daq.clock is not None and daq.clock.spread_rows:
        timing["stamp_rows_spread"] = daq.clock.spread_rows
    if not win.accepted:
        info["no_points_note"] = steady.why_no_windows(
            win, float(np.sum(usable)) * dt, timing["duration_s"], dt, config)
    return SessionOutput(points=points, rejected=rejected, samples_path=samples_path, info=info)


def _unlogged_holds(a_t: np.ndarray, a_p: np.ndarray, interval: float, t0: float, dt: float,
                    gap: np.ndarray, win: steady.Windows,
                    config: steady.SteadyConfig) -> list[tuple[float, float, str]]:
    """Holds of the analyzer's power where the DAQ logged nothing (before its first sample,
    after its last, in a gap of it): rejected windows ``(t_start, t_end, reason)`` [s].

    ``a_t``, ``a_p``: the analyzer's record (middles of its intervals on the DAQ clock
    [s], power [W]); ``gap``: the DAQ bins of a gap. A hold of power
    (:func:`steady.held_runs` on the records, the power tolerance of ``win``) that
    continues an accepted window's setpoint is that point's.
    """
    n_bins = gap.size
    b = np.floor((a_t - t0) / dt).astype(np.int64)
    unlogged = (b < 0) | (b >= n_bins) | gap[np.clip(b, 0, n_bins - 1)]
    if not unlogged.any():
        return []
    k = np.searchsorted(a_t, t0 + np.array(win.accepted, float).reshape(-1, 2) * dt)
    points = [(int(i), int(j)) for i, j in np.clip(k, 0, a_t.size) if j > i]
    holds = steady.held_runs({"power": a_p}, unlogged & np.isfinite(a_p),
                             np.zeros(a_t.size, bool), {"power": win.tolerances["power"]},
                             replace(config, bin_s=interval), points=points)
    return [(float(a_t[i] - interval / 2), float(a_t[j - 1] + interval / 2), "no logger samples")
            for i, j in holds]


def recorded_bins(centres: np.ndarray, t_records: np.ndarray, max_step_s: float) -> np.ndarray:
    """Bins the power analyzer recorded: inside its record and not in a gap of it.

    ``t_records``: the analyzer's valid sample times on the DAQ clock (ascending) [s];
    a bin centre between two records more than ``max_step_s`` apart (a gap) or
    outside the first and last record is not recorded.
    """
    k = np.searchsorted(t_records, centres)
    inside = (k > 0) & (k < t_records.size)
    kk = np.clip(k, 1, max(t_records.size - 1, 1))
    step = t_records[kk] - t_records[kk - 1]
    on = np.isin(centres, t_records)
    return (inside & (step <= max_step_s)) | on


def fold_signed(speed_rpm: np.ndarray, torque_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed torque into the drum frame: where torque < 0, flip speed and torque.

    A bench that logs generator mode as speed > 0, torque < 0 then gives
    torque >= 0 and reel-out (generating) as negative speed; p_mech is unchanged.
    """
    neg = torque_nm < 0
    return np.where(neg, -speed_rpm, speed_rpm), np.where(neg, -torque_nm, torque_nm)


def check_drum_torque(session: Session, torque_nm: np.ndarray, tol_nm: float,
                      where: Path) -> None:
    """Raise when operating points have negative drum torque (against the drum frame).

    A point counts when its mean torque is below ``-tol_nm`` (the steady tolerance,
    so a no-load point at 0 +- noise passes).
    """
    neg = np.flatnonzero(np.asarray(torque_nm) < -tol_nm)
    if neg.size:
        raise InputError(
            where, f"{neg.size} of {len(torque_nm)} operating points have negative drum torque "
            f"(down to {float(np.min(torque_nm)):.4g} N m)", column="torque",
            expected="torque >= 0 in the drum frame: torque_sign = \"signed\" in "
            f"{session.path.name} when the bench logs generator mode as torque < 0 (speed and "
            "torque are then flipped where torque < 0), or torque_sign = -1 when every torque "
            "is logged with the opposite sign",
        )


def _screen_windows(win: steady.Windows, means: dict, p_elec_bins: np.ndarray, sources: dict,
                    session: Session, where: Path, standstill_rpm: float) -> steady.Windows:
    """Check the accepted windows' means (:func:`checks.check_points`): stop on a systematic
    error, move the few implausible windows to the rejected ones with their reason.

    A window whose mean |speed| is below ``standstill_rpm`` [rpm] (the tare's standstill
    limit) is the drive at rest, not an operating point: rejected as ``standstill``
    (a noisy fast logger's leading standstill, where no tare was found, or a stop)."""
    for q in ("speed", "torque"):
        checks.check_signal(sources[q], q, means[q], False)
    if not win.accepted:
        return win

    a, b = np.array(win.accepted).T

    def window_means(x: np.ndarray) -> np.ndarray:
        fin = np.isfinite(x)
        s = np.concatenate(([0.0], np.cumsum(np.where(fin, x, 0.0))))
        c = np.concatenate(([0], np.cumsum(fin)))
        with np.errstate(invalid="ignore", divide="ignore"):
            return (s[b] - s[a]) / (c[b] - c[a])

    values = {"speed": window_means(means["speed"]), "torque": window_means(means["torque"]),
              "p_elec": window_means(p_elec_bins)}
    if "p_mech_logged" in means:  # a single-stream log's mapped p_mech, checked against omega*T
        values["p_mech"] = window_means(means["p_mech_logged"])
    why = checks.check_points(values, sources, checks.explicit_ranges(session), where)
    why = ["standstill" if abs(v) < standstill_rpm else w
           for v, w in zip(values["speed"], why, strict=True)]
    if all(w is None for w in why):
        return win
    accepted = [ab for ab, w in zip(win.accepted, why, strict=True) if w is None]
    rejected = sorted(win.rejected + [(a, b, w) for (a, b), w in zip(win.accepted, why,
                                                                       strict=True) if w])
    return steady.Windows(accepted=accepted, rejected=rejected, tolerances=win.tolerances)


def _check_analyzer(path: Path, frame, meta: dict, layout) -> None:
    from bench.ingest.readers import line_of_row

    where = lambda row: line_of_row(layout, row)  # noqa: E731
    t = frame["time_s"].to_numpy()
    for q, x in (("time", t), ("p_elec", frame["p_elec_w"].to_numpy())):
        chk = NanRunCheck(path, meta["columns"][q]["column"], where)
        chk.feed(x, 0)
        chk.finish()
    steps = np.diff(t[np.isfinite(t)])
    typical = float(np.median(steps)) if steps.size and np.median(steps) > 0 else None
    TimeCheck(path, meta["columns"]["time"]["column"], where, typical).feed(t, 0)
    if np.isnan(t).any():
        frame.drop(index=frame.index[np.isnan(t)], inplace=True)
    if len(frame) < 20:
        raise InputError(path, f"only {len(frame)} analyzer samples", expected="at least 20")


def _prior_offset(session: Session, ameta: dict, daq: DaqStream) -> float:
    from datetime import datetime

    d0 = daq.clock.start if daq.clock is not None else session.daq_start()
    a0 = ameta.get("start")
    if d0 is None or a0 is None:
        return 0.0
    return (datetime.fromisoformat(a0) - d0).total_seconds()


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


class _WindowStats:
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
        return points_table(session, cols, np.rint(self.count).astype(np.int32), w_start, w_end,
                            "timeseries")


def points_table(session: Session, cols: dict, n_samples, t_start, t_end,
                 source: str) -> pa.Table:
    """Assemble the points table (store schema) of one session.

    Parameters
    ----------
    session : Session
        Gives ``session_id`` and ``mode``.
    cols : dict
        ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w`` and their ``*_std``
        arrays in the drum frame [rpm, N m, W].
    n_samples : array
        Samples averaged per point.
    t_start, t_end : array
        Window bounds on the DAQ clock [s] (NaN for tables).
    source : str
        ``"timeseries"`` or ``"operating_point_table"``.
    """
    data = {k: np.asarray(v, np.float64) for k, v in cols.items()}
    m = len(n_samples)
    arrays = {
        "session_id": pa.array([session.session_id] * m, pa.string()),
        "point_id": pa.array(np.arange(m, dtype=np.int32)),
        "mode": pa.array([session.mode] * m, pa.string()),
        "quadrant": pa.array(steady.quadrant(data["p_mech_w"]).tolist(), pa.string()),
        "source": pa.array([source] * m, pa.string()),
        **{k: pa.array(data[k]) for k in (
            "speed_rpm", "torque_nm", "p_mech_w", "p_elec_w",
            "speed_rpm_std", "torque_nm_std", "p_mech_w_std", "p_elec_w_std")},
        "n_samples": pa.array(np.asarray(n_samples, np.int64)),
        "t_start_s": pa.array(np.asarray(t_start, np.float64)),
        "t_end_s": pa.array(np.asarray(t_end, np.float64)),
    }
    return pa.table(arrays, schema=POINTS_SCHEMA)


def rejected_table(sid: str, rows: list[tuple[float, float, str]]) -> pa.Table:
    return pa.table({
        "session_id": pa.array([sid] * len(rows), pa.string()),
        "t_start_s": pa.array([r[0] for r in rows], pa.float64()),
        "t_end_s": pa.array([r[1] for r in rows], pa.float64()),
        "reason": pa.array([r[2] for r in rows], pa.string()),
    }, schema=REJECTED_SCHEMA)
