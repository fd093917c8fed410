"""One timeseries session: DAQ stream + analyzer -> aligned samples, points, rejections.

Two passes over the DAQ so memory does not grow with the file:

1. Stream the DAQ file in chunks (:mod:`scan`): check time and NaN runs, map
   into the drum frame, spill time/speed/torque to raw float64 scratch files,
   accumulate bin sums (:mod:`bins`), and collect the leading standstill
   (:mod:`tare`). Subtract the flange zero offset the tare gives from the bin
   means, align the analyzer on the bins (:mod:`analyzer`, :mod:`align`), check
   the torque sign, detect steady windows (:mod:`steady`) after the tare.
2. Stream the scratch files back (:mod:`samples_file`): subtract the zero offset,
   as-of join the analyzer power, tag samples with their window, accumulate exact
   window statistics, and write the samples Parquet file row group by row group.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from bench.ingest import checks, steady
from bench.ingest.analyzer import (
    AlignedPower,
    AnalyzerRecord,
    align_analyzer,
    read_checked_analyzer,
    unlogged_holds,
)
from bench.ingest.checks import check_torque_sign
from bench.ingest.clock import TIME_OF_DAY
from bench.ingest.csv_stream import CHUNK_BYTES
from bench.ingest.daq_stream import DaqStream, open_daq_csv, open_daq_tdms
from bench.ingest.drum_frame import check_drum_torque, drum_ranges
from bench.ingest.mapping import Mapping
from bench.ingest.samples_file import write_samples
from bench.ingest.scan import Binned, StreamScan, bin_stream, scan_stream
from bench.ingest.session import Session
from bench.ingest.store_tables import SessionOutput, rejected_table
from kernel.errors import InputError


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


def session_electrical_power(session: Session, daq: DaqStream,
                             record: AnalyzerRecord | None, binned: Binned, scan: StreamScan,
                             sources: dict, config: steady.SteadyConfig) -> AlignedPower:
    """The electrical power on the bins: a single-stream log's own, or the analyzer's
    aligned to the DAQ clock."""
    if record is None:
        p_elec_bins = binned.means["p_elec"]
        checks.check_signal(sources["p_elec"], "p_elec", p_elec_bins, True)
        return AlignedPower(p_elec_bins=p_elec_bins, recorded=np.ones(binned.n_bins, bool))
    return align_analyzer(record, session, daq, binned, scan.peak, config)


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


def _session_windows(session: Session, daq: DaqStream, binned: Binned, power: AlignedPower,
                     sources: dict, standstill_rpm: float,
                     config: steady.SteadyConfig) -> tuple[steady.Windows, np.ndarray]:
    """The session's steady windows (bin indices) after the tare, screened, with the held
    setpoints the analyzer did not record rejected; and the bins they were looked for in."""
    means, n_bins = binned.means, binned.n_bins
    recorded = power.recorded
    # the tare is no window
    after_tare = (binned.t0 + np.arange(n_bins) * binned.dt >= binned.zero.t_motion_s
                  if binned.zero is not None else np.ones(n_bins, bool))
    usable = recorded & after_tare
    win = steady.find_windows(means["speed"], means["torque"], power.p_elec_bins,
                              means["valid_frac"], drum_ranges(session), config, usable=usable,
                              cuts=means["cuts"])
    win = _screen_windows(win, means, power.p_elec_bins, sources, session, daq.path,
                          standstill_rpm)
    if not recorded.all():  # held setpoints the analyzer did not record: rejected, said
        gap = binned.gap()
        holds = steady.held_runs({"speed": means["speed"], "torque": means["torque"]},
                                 ~recorded & after_tare & ~gap, gap, win.tolerances, config,
                                 points=win.accepted)
        win = replace(win, rejected=sorted(win.rejected + [
            (a, b, "no analyzer samples") for a, b in holds]))
    return win, usable


def session_info(daq: DaqStream, record: AnalyzerRecord | None, clock, binned: Binned,
                 scan: StreamScan, win: steady.Windows, usable: np.ndarray,
                 config: steady.SteadyConfig) -> dict:
    """The session's manifest fields: clock offset/drift, torque zero, counts, timing,
    instruments."""
    zero, timing = binned.zero, binned.timing
    instruments = ({"log": daq.metadata} if record is None
                   else {"daq": daq.metadata, "analyzer": record.meta})
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
        **({} if zero is not None else {"torque_zero_note": binned.no_tare_why}),
        "n_samples": int(scan.n_rows),
        "n_rows_without_time": int(scan.n_total - scan.n_rows),
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
            win, float(np.sum(usable)) * binned.dt, timing["duration_s"], binned.dt, config)
    return info


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
    daq = open_stream(session, mapping, chunk_bytes)
    if daq.clock is not None and daq.clock.unit == TIME_OF_DAY and session.day() is None:
        raise InputError(session.path, f"{daq.path.name} gives the time of day only, and "
                         "session.toml has no date", column="date",
                         expected='date = "YYYY-MM-DD", the day the log starts')
    sources = checks.sources_from_meta(daq.path, daq.metadata["columns"])
    record = (None if session.single_stream
              else read_checked_analyzer(session, mapping, sources))
    # per-sample quantities besides time, speed, torque
    extra = tuple(q for q in ("p_elec", "p_mech") if q in daq.metadata["columns"])

    scan = scan_stream(session, daq, extra, scratch, config, progress)  # pass 1
    binned = bin_stream(scan, daq, config)
    config = replace(config, bin_s=binned.dt)
    power = session_electrical_power(session, daq, record, binned, scan, sources, config)
    check_torque_sign(session, binned.means["p_mech"], power.p_elec_bins, daq.path)
    win, usable = _session_windows(session, daq, binned, power, sources, scan.tare.limit_rpm,
                                   config)
    unlogged = [] if record is None else unlogged_holds(power, binned, win, config)
    t0, dt = binned.t0, binned.dt
    w_start = np.array([t0 + a * dt for a, _ in win.accepted])
    w_end = np.array([t0 + b * dt for _, b in win.accepted])

    samples_path = scratch / f"{sid}.samples.parquet"  # pass 2
    stats = write_samples(samples_path, session, scan, binned.offset_nm,
                          None if record is None else power, w_start, w_end, progress,
                          daq.size_bytes)
    points = stats.points_table(session, w_start, w_end)
    if not session.signed_torque:
        check_drum_torque(session, points.column("torque_nm").to_numpy(),
                          win.tolerances["torque"], daq.path)
    rejected = rejected_table(sid, sorted(
        [(t0 + a * dt, t0 + b * dt, r) for a, b, r in win.rejected] + unlogged))
    info = session_info(daq, record, power.clock, binned, scan, win, usable, config)
    notes = [n for n in (chk.note() for chk in scan.temps.values()) if n is not None]
    if notes:  # flagged temperature channels, not stored
        info["temperature_notes"] = notes
    return SessionOutput(points=points, rejected=rejected, samples_path=samples_path, info=info)
