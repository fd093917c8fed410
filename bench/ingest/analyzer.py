"""The power analyzer of a DAQ + analyzer session: its record read and checked, put on
the DAQ clock (:mod:`bench.ingest.align`), and the bins and holds it covers."""

from __future__ import annotations

from dataclasses import dataclass, replace
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest import align, checks, steady
from bench.ingest.csv_layout import line_of_row
from bench.ingest.daq_stream import DaqStream
from bench.ingest.mapping import Mapping
from bench.ingest.readers import read_analyzer
from bench.ingest.scan import Binned, PeakSample
from bench.ingest.scrub import NanRunCheck, TimeCheck
from bench.ingest.session import Session
from kernel.errors import InputError

#: smallest |correlation| of analyzer and DAQ power steps that counts as aligned [-]
MIN_ALIGN_CORRELATION = 0.3


@dataclass
class AnalyzerRecord:
    """A power analyzer's record, read and checked.

    Parameters
    ----------
    path : Path
        Its file.
    frame : pandas.DataFrame
        ``time_s`` (its own clock) and ``p_elec_w`` [W], rows without a time dropped.
    meta : dict
        What the reader found (columns, start time, ...).
    """

    path: Path
    frame: pd.DataFrame
    meta: dict


def _check_analyzer(path: Path, frame, meta: dict, layout) -> None:
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


def read_checked_analyzer(session: Session, mapping: Mapping,
                          sources: dict[str, checks.Source]) -> AnalyzerRecord:
    """Read the session's ``[analyzer]`` file and check it; add its source to ``sources``.

    Raises
    ------
    InputError
        Bad times, NaN runs, fewer than 20 samples, a constant or implausible power.
    """
    path = session.file("analyzer")
    frame, meta = read_analyzer(path, mapping, day=session.day())
    layout = meta.pop("layout")
    _check_analyzer(path, frame, meta, layout)
    sources.update(checks.sources_from_meta(path, meta["columns"]))
    checks.check_signal(sources["p_elec"], "p_elec", frame["p_elec_w"].to_numpy(), True)
    return AnalyzerRecord(path=path, frame=frame, meta=meta)


def _prior_offset(session: Session, ameta: dict, daq: DaqStream) -> float:
    d0 = daq.clock.start if daq.clock is not None else session.daq_start()
    a0 = ameta.get("start")
    if d0 is None or a0 is None:
        return 0.0
    return (datetime.fromisoformat(a0) - d0).total_seconds()


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


@dataclass
class AlignedPower:
    """The electrical power on the DAQ's bins.

    Parameters
    ----------
    p_elec_bins : numpy.ndarray
        Electrical power per bin [W] (NaN where not recorded).
    recorded : numpy.ndarray
        True for the bins the power was recorded in.
    clock : ClockModel or None
        The analyzer's clock on the DAQ's (None for a single-stream log).
    t_s, p_w : numpy.ndarray or None
        The analyzer's records on the DAQ clock (middles of its update intervals)
        [s] and their power [W] (None for a single-stream log).
    interval_s : float
        The analyzer's update interval [s] (NaN for a single-stream log).
    """

    p_elec_bins: np.ndarray
    recorded: np.ndarray
    clock: align.ClockModel | None = None
    t_s: np.ndarray | None = None
    p_w: np.ndarray | None = None
    interval_s: float = float("nan")


def align_analyzer(record: AnalyzerRecord, session: Session, daq: DaqStream, binned: Binned,
                   peak: PeakSample, config: steady.SteadyConfig) -> AlignedPower:
    """Put the analyzer's record on the DAQ clock and its power on the DAQ's bins.

    Raises
    ------
    InputError
        The analyzer's power does not follow the DAQ's speed x torque (naming a DAQ
        spike when one is at fault).
    """
    prior = _prior_offset(session, record.meta, daq)
    # a power analyzer's record is the mean over the update interval that ends at its
    # time stamp: it stands for the middle of that interval
    t_own = record.frame["time_s"].to_numpy()
    interval = float(np.median(np.diff(t_own)))
    a_mid = t_own - 0.5 * interval
    a_p = record.frame["p_elec_w"].to_numpy()
    centres = binned.centres()
    p_mech = binned.means["p_mech"]
    clock = align.estimate_clock(centres, p_mech, a_mid, a_p, prior)
    if abs(clock.correlation) < MIN_ALIGN_CORRELATION:
        peak.check(daq, p_mech)  # a DAQ spike, not the analyzer, may be at fault
        raise InputError(
            record.path, "analyzer power does not follow the DAQ's speed x torque (peak "
            f"correlation {clock.correlation:.2f} within {align.MAX_LAG_S:g} s of the header "
            "start times)", expected="the power-analyzer record of the same bench run as "
            f"{daq.path.name}, overlapping it in time",
        )
    a_t = clock.to_daq(a_mid)
    fin = np.flatnonzero(np.isfinite(a_p))
    p_elec_bins = np.interp(centres, a_t[fin], a_p[fin], left=np.nan, right=np.nan)
    recorded = recorded_bins(centres, a_t[fin], interval * config.gap_factor)
    return AlignedPower(p_elec_bins=p_elec_bins, recorded=recorded, clock=clock, t_s=a_t,
                        p_w=a_p, interval_s=interval)


def unlogged_holds(power: AlignedPower, binned: Binned, win: steady.Windows,
                   config: steady.SteadyConfig) -> list[tuple[float, float, str]]:
    """Holds of the analyzer's power where the DAQ logged nothing (before its first sample,
    after its last, in a gap of it): rejected windows ``(t_start, t_end, reason)`` [s].

    A hold of power (:func:`steady.held_runs` on the records, the power tolerance of
    ``win``) that continues an accepted window's setpoint is that point's.
    """
    a_t, a_p, interval = power.t_s, power.p_w, power.interval_s
    t0, dt, gap = binned.t0, binned.dt, binned.gap()
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
