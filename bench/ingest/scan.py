"""Pass 1 over a session's DAQ stream, in chunks so memory does not grow with the file.

Each chunk is checked (time, NaN runs), mapped into the drum frame, its time,
speed and torque (and a single-stream log's p_elec) spilled to raw float64
scratch files for pass 2 (:mod:`bench.ingest.samples_file`), and added to the bin
sums (:mod:`bench.ingest.bins`) and to the search for the leading standstill
(:mod:`bench.ingest.tare`). :func:`bin_stream` then gives the bin means with the
torque zero offset off.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.ingest import steady, tare
from bench.ingest.bins import StreamBins
from bench.ingest.daq_stream import DaqStream
from bench.ingest.drum_frame import drum_ranges, to_drum_frame
from bench.ingest.scrub import NanRunCheck, TimeCheck
from bench.ingest.session import Session
from bench.ingest.temperature import TEMPERATURES, TemperatureCheck
from kernel.errors import InputError


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


class PeakSample:
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


class StreamScan:
    """The state of pass 1: checks, bin sums, tare search, scratch files, counts.

    Parameters
    ----------
    session : Session
        Its metadata (drum frame, single stream or not).
    daq : DaqStream
        The opened stream.
    extra : tuple of str
        Per-sample quantities besides time, speed, torque the stream holds
        (``p_elec``, ``p_mech`` of a single-stream log).
    scratch : Path
        The staging directory the scratch files go to.
    config : SteadyConfig
        Gives the narrowest bin and the gap factor.
    """

    def __init__(self, session: Session, daq: DaqStream, extra: tuple[str, ...],
                 scratch: Path, config: steady.SteadyConfig) -> None:
        self.session = session
        self.extra = extra
        self.bin_names = {q: "p_mech_logged" if q == "p_mech" else q for q in extra}
        self.bins = StreamBins(config, extra=tuple(self.bin_names.values()))
        cols = daq.metadata["columns"]
        self.tcheck = TimeCheck(daq.path, cols["time"]["column"], daq.line_of_row, config.bin_s)
        self.nan_checks = {q: NanRunCheck(daq.path, cols[q]["column"], daq.line_of_row)
                           for q in ("time", "speed", "torque") + extra}
        ranges = drum_ranges(session)
        self.tare = tare.TareFinder(ranges["speed"], ranges["torque"])
        sid = session.session_id
        #: quantity -> its scratch file of raw float64 values
        #: the temperature channels the stream holds, each with its checks (degC)
        self.temps = {q: TemperatureCheck(daq.path, q, cols[q]["column"], cols[q]["unit"],
                                          daq.line_of_row)
                      for q in TEMPERATURES if q in cols}
        self.spill = {q: scratch / f"{sid}.{q}.f64"
                      for q in ("time", "speed", "torque")
                      + (("p_elec",) if session.single_stream else ()) + tuple(self.temps)}
        self._handles = {q: open(p, "wb") for q, p in self.spill.items()}
        self._spilled = dict.fromkeys(self._handles, 0)
        self.peak = PeakSample()
        #: rows with a time (kept) and all rows read
        self.n_rows = self.n_total = 0

    def feed(self, chunk) -> None:
        """Check, bin and spill one chunk of the stream."""
        v = chunk.values
        for q, chk in self.nan_checks.items():
            chk.feed(v[q], chunk.row0)
        self.tcheck.feed(v["time"], chunk.row0)
        t = v["time"]
        speed, torque = to_drum_frame(self.session, v["speed"], v["torque"])
        self.peak.feed(speed, torque, chunk.row0)
        more = {q: v[q] for q in self.extra}
        temps = {q: v[q] for q in self.temps}
        for q, chk in self.temps.items():
            chk.feed(temps[q], chunk.row0)
        if "p_mech" in more:  # logged in the bench's frame: to the drum frame's sign
            more["p_mech"] = more["p_mech"] * (self.session.speed_sign
                                               * self.session.torque_sign)
        self.n_total += t.size
        keep = np.isfinite(t)
        if not keep.all():
            t, speed, torque = t[keep], speed[keep], torque[keep]
            more = {q: x[keep] for q, x in more.items()}
            temps = {q: x[keep] for q, x in temps.items()}
        if t.size:
            self.tare.feed(t, speed, torque)
            self.bins.add(t, speed, torque, **{self.bin_names[q]: x for q, x in more.items()})
            for q, arr in (("time", t), ("speed", speed), ("torque", torque), *more.items(),
                           *temps.items()):
                if q in self._handles:
                    _spill(arr, self._handles[q], self.spill[q])
                    self._spilled[q] += arr.nbytes
            self.n_rows += t.size

    def finish(self) -> None:
        """The NaN-run checks' last runs."""
        for chk in self.nan_checks.values():
            chk.finish()

    def close(self) -> None:
        """Close the scratch files."""
        for h in self._handles.values():
            h.close()

    def check_written(self) -> None:
        """Raise InputError naming the store when a scratch file is short (a full disk can
        fail a buffered write without a word)."""
        for q, n in self._spilled.items():
            if self.spill[q].stat().st_size != n:
                _disk_full(self.spill[q], f"{self.spill[q].stat().st_size} of {n} bytes written")


def scan_stream(session: Session, daq: DaqStream, extra: tuple[str, ...], scratch: Path,
                config: steady.SteadyConfig,
                progress: Callable[[int], None]) -> StreamScan:
    """Pass 1: read the whole stream once (see :class:`StreamScan`).

    Raises
    ------
    InputError
        A bad time or NaN run (naming the line), a full disk, no data rows.
    """
    scan = StreamScan(session, daq, extra, scratch, config)
    try:
        for chunk in daq.chunks():
            scan.feed(chunk)
            progress(chunk.nbytes // 2)
        scan.finish()
    finally:
        scan.close()
    scan.check_written()
    if scan.n_rows == 0:
        raise InputError(daq.path, "no data rows", expected="DAQ samples")
    return scan


@dataclass
class Binned:
    """The stream's bins after pass 1.

    Parameters
    ----------
    means : dict
        Bin means (:meth:`StreamBins.means`) with the torque zero offset off.
    t0 : float
        Start of the bin grid on the DAQ clock [s].
    dt : float
        Bin width [s].
    timing : dict
        Sample interval, bin width, gap threshold, gap count, duration [s] (manifest).
    zero : Tare or None
        The torque zero offset found at the leading standstill.
    no_tare_why : str
        Why there is none.
    """

    means: dict[str, np.ndarray]
    t0: float
    dt: float
    timing: dict
    zero: tare.Tare | None
    no_tare_why: str

    @property
    def n_bins(self) -> int:
        """Bins from the first sample's to the last's."""
        return self.means["speed"].size

    @property
    def offset_nm(self) -> float:
        """The torque zero offset [N m] (0 without a tare)."""
        return self.zero.offset_nm if self.zero is not None else 0.0

    def centres(self) -> np.ndarray:
        """Bin centres on the DAQ clock [s]."""
        return self.t0 + (np.arange(self.n_bins) + 0.5) * self.dt

    def gap(self) -> np.ndarray:
        """The bins of a gap of the logger (in a cut, without a valid sample)."""
        return self.means["cuts"] & ~(self.means["valid_frac"] > 0)


def bin_stream(scan: StreamScan, daq: DaqStream, config: steady.SteadyConfig) -> Binned:
    """The bin means of a scanned stream, the torque zero offset off.

    Raises
    ------
    InputError
        A recording shorter than the shortest steady window.
    """
    bins = scan.bins
    n_bins = int(np.flatnonzero(bins.sums["rows"])[-1]) + 1
    if n_bins * config.bin_s < config.min_window_s:  # nothing to align or average
        raise InputError(daq.path, f"only {scan.n_rows} data row(s), "
                         f"{n_bins * config.bin_s:g} s of recording",
                         expected=f"a recording longer than the shortest "
                         f"steady window ({config.min_window_s:g} s)")
    zero, no_tare_why = scan.tare.result()
    means = bins.means(n_bins, zero.offset_nm if zero is not None else 0.0)
    timing = {"sample_interval_s": round(bins.interval_s, 9), "bin_s": round(bins.dt, 9),
              "gap_threshold_s": round(bins.gap_s, 9) if math.isfinite(bins.gap_s) else None,
              "n_gaps": bins.n_gaps, "duration_s": round(bins.last_t - bins.t0, 6)}
    return Binned(means=means, t0=bins.t0, dt=bins.dt, timing=timing, zero=zero,
                  no_tare_why=no_tare_why)
