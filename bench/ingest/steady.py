"""Steady-state windows: settle after each setpoint step, then keep what is stable.

Works on short-bin means of speed, torque and power. The bins are
``bin_s`` wide (0.1 s by default; the caller widens them to the sample
interval of a slower logger, so that a bin holds about one sample or more).
Every duration below is in seconds and converted to bins with the bin width,
so a 0.5 Hz logger and a 10 kHz DAQ give the same windows for the same run.
An empty bin (no sample fell into it: jitter of a slow logger) or one whose
samples are all invalid is no break by itself; a *gap* is (``cuts``: a hole
in the time axis or a run of invalid samples longer than
:func:`gap_threshold_s`, found by the caller):

1. Noise per bin of each signal from the median absolute bin-to-bin difference
   (robust: steps are rare). Tolerance = ``k_tol`` noise sigmas, at least a
   small fraction of the sensor's range.
2. A bin is *moving* when the mean of the next ``step_lag_s`` differs from the
   mean of the previous ``step_lag_s`` by more than ``k_step`` tolerances in
   speed or torque. Runs of non-moving bins are the candidate segments, one per setpoint.
3. Settling: the segment starts after the last bin that is off the segment's
   final level (mean of its second half) by more than the tolerance in speed
   or torque; it ends before its last bins (at most ``step_lag_s``) that are
   off that level in speed, torque or power (the next step already begun).
4. Checks, in order, each giving a rejection reason: ``too short`` (under
   ``min_window_s``, or data in fewer than ``min_samples`` bins),
   ``invalid samples`` (more than ``max_invalid`` of the
   samples are NaN), ``speed unstable``, ``torque unstable``, ``power unstable``
   (standard deviation of the bin means above the tolerance).
5. An oscillation too strong or too slow to stay one segment (a hunting brake)
   is cut by step 2 into pieces too short to report. A stretch between two
   reported segments that is at least ``min_window_s`` long and holds at least
   ``oscillation_pieces`` such pieces is reported as unstable (the first of
   speed, torque, power whose standard deviation over it exceeds the tolerance);
   a setpoint step leaves at most one piece.
6. Every stretch of held setpoint is a point or a rejected window: a stretch of
   usable bins that no window of steps 4-5 covers (``too short`` pieces aside),
   at least twice ``min_window_s`` and longer than a step's transition (``4
   step_lag_s`` plus two bins), whose speed and torque end where they began (the
   medians of its first and last quarter within ``k_step`` tolerances: a hold, not
   a ramp), checked as in step 4, is one rejected window with that reason,
   replacing the ``too short`` pieces inside it (when it passes, the pieces stand).
   This catches a hold whose scatter exceeds the session's noise so much that step
   2 breaks it up (a slow logger's bins are single samples). Rejected windows that
   touch and share their reason are one window. A hold where the DAQ logs but the
   power analyzer has no samples (before its record begins, after it ends, in a gap
   of it) is found by :func:`held_runs` and rejected by the caller with that reason,
   unless the same setpoint is a point where the analyzer recorded it.

Long sessions are handled in blocks of :data:`BLOCK_BINS`, each cut at a moving
bin, so the result equals the whole-series one while memory stays bounded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SteadyConfig:
    """Steady-state detection settings.

    Parameters
    ----------
    bin_s : float
        Bin width of the means the detection works on [s].
    step_lag_s : float
        Length of the two means compared to flag a moving signal [s].
    min_window_s : float
        Shortest accepted window after settling [s].
    k_tol : float
        Tolerance in noise standard deviations of a bin mean [-].
    k_step : float
        A setpoint step is a change of the lagged means above ``k_step`` tolerances [-]
        (larger than 1 so that an oscillating signal stays one segment and is
        rejected as unstable rather than cut into short pieces).
    floor_frac : float
        Smallest tolerance as a fraction of the sensor range [-].
    max_invalid : float
        Largest accepted fraction of invalid samples in a window [-].
    min_report_s : float
        Segments shorter than this are transients, not reported as rejected [s].
    oscillation_pieces : int
        Unreported pieces between two segments from which the stretch is an
        oscillation, reported as unstable [-].
    min_samples : int
        A window also needs data in at least this many bins (so at least as many
        samples), so that its standard deviation means something: it binds only
        for loggers slower than ``min_samples / min_window_s`` [-].
    gap_factor : float
        A step in the time axis longer than ``gap_factor`` median sample
        intervals (and longer than one bin) is a gap and ends a window [-].
    """

    bin_s: float = 0.1
    step_lag_s: float = 0.5
    min_window_s: float = 2.0
    k_tol: float = 5.0
    k_step: float = 3.0
    floor_frac: float = 0.001
    max_invalid: float = 0.2
    min_report_s: float = 1.0
    oscillation_pieces: int = 3
    min_samples: int = 3
    gap_factor: float = 5.0


DEFAULT_STEADY = SteadyConfig()

#: bins handled at a time (one hour at 0.1 s); bounds memory for long sessions
BLOCK_BINS = 36_000


def bin_width_s(sample_interval_s: float, config: SteadyConfig) -> float:
    """Bin width for a logger with this median sample interval [s].

    ``config.bin_s``, widened to the sample interval when the logger is slower,
    so that no bin is empty on a regular grid.
    """
    if not np.isfinite(sample_interval_s) or sample_interval_s <= 0:
        return config.bin_s
    return max(config.bin_s, float(sample_interval_s))


def gap_threshold_s(sample_interval_s: float, config: SteadyConfig) -> float:
    """Longest step in the time axis that is not a gap [s].

    ``gap_factor`` median sample intervals, and at least one bin: a shorter
    hole leaves no bin empty, and the lagged means see across it.
    """
    return max(config.gap_factor * sample_interval_s, bin_width_s(sample_interval_s, config))


@dataclass(frozen=True)
class Windows:
    """Accepted and rejected windows, as bin index ranges ``[start, stop)``.

    Parameters
    ----------
    accepted : list of tuple
        ``(start_bin, stop_bin)`` per operating point.
    rejected : list of tuple
        ``(start_bin, stop_bin, reason)``.
    tolerances : dict
        Tolerance used per signal (``speed``, ``torque``, ``power``) [rpm, N m, W].
    """

    accepted: list[tuple[int, int]]
    rejected: list[tuple[int, int, str]]
    tolerances: dict[str, float]


def noise_sigma(x: np.ndarray) -> float:
    """Noise standard deviation of a step-wise signal from its increments [same unit]."""
    d = np.diff(x)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d)) / np.sqrt(2.0))


def _moving(x: np.ndarray, lag: int, tol: float) -> np.ndarray:
    """True where the means of the ``lag`` bins after and before differ by more than ``tol``."""
    ok = np.isfinite(x)
    cs = np.concatenate(([0.0], np.cumsum(np.where(ok, x, 0.0))))
    cn = np.concatenate(([0], np.cumsum(ok)))
    n = x.size
    i = np.arange(n)
    a0, a1 = np.clip(i - lag, 0, n), i
    b0, b1 = i, np.clip(i + lag, 0, n)
    na, nb = cn[a1] - cn[a0], cn[b1] - cn[b0]
    with np.errstate(invalid="ignore", divide="ignore"):
        ma = (cs[a1] - cs[a0]) / na
        mb = (cs[b1] - cs[b0]) / nb
    diff = np.abs(mb - ma)
    return np.where((na > 0) & (nb > 0), diff > tol, False)


def find_windows(
    speed_rpm: np.ndarray,
    torque_nm: np.ndarray,
    p_elec_w: np.ndarray,
    valid_frac: np.ndarray,
    ranges: dict[str, float],
    config: SteadyConfig | None = None,
    usable: np.ndarray | None = None,
    cuts: np.ndarray | None = None,
) -> Windows:
    """Find the steady-state window of each setpoint in bin-mean series.

    Parameters
    ----------
    speed_rpm, torque_nm, p_elec_w : array
        Bin means (NaN for empty bins) [rpm, N m, W].
    valid_frac : array
        Fraction of valid samples per bin [-] (NaN for an empty bin).
    ranges : dict
        Sensor ranges ``speed``, ``torque``, ``power`` [rpm, N m, W] for the tolerance floors.
    config : SteadyConfig, optional
        Detection settings (default :data:`DEFAULT_STEADY`).
    usable : array of bool, optional
        False for bins no window may cover (e.g. outside the analyzer's record).
    cuts : array of bool, optional
        True for the bins of a gap (empty or all invalid) and the first bin
        after it: no window spans the gap.

    Returns
    -------
    Windows
    """
    config = DEFAULT_STEADY if config is None else config
    tol = tolerances(speed_rpm, torque_nm, p_elec_w, ranges, config)
    lag = max(1, int(round(config.step_lag_s / config.bin_s)))
    cuts = np.zeros(speed_rpm.size, bool) if cuts is None else cuts
    usable = np.ones(speed_rpm.size, bool) if usable is None else usable
    series = (speed_rpm, torque_nm, p_elec_w, valid_frac, cuts, usable)
    mask_inputs = (speed_rpm, torque_nm, valid_frac, usable, cuts)
    n = speed_rpm.size
    accepted: list[tuple[int, int]] = []
    rejected: list[tuple[int, int, str]] = []
    start = 0
    while start < n:
        # blocks of BLOCK_BINS cut inside a transition, so memory does not grow with
        # the session's length and no window straddles two blocks
        end = min(start + BLOCK_BINS, n)
        if end < n:
            hi = min(end + BLOCK_BINS // 4, n)
            lo = end - lag
            moving = _moving_mask(*(x[lo:hi] for x in mask_inputs), tol, lag, config)
            after = np.flatnonzero(moving[lag:])
            end = end + int(after[0]) if after.size else end
        # the mask needs lag bins of context on each side to equal the whole series'
        lo, hi = max(start - lag, 0), min(end + lag, n)
        moving = _moving_mask(*(x[lo:hi] for x in mask_inputs), tol, lag, config)
        moving = moving[start - lo:start - lo + end - start]
        acc, rej = _block_windows(moving, *(x[start:end] for x in series), tol, config)
        accepted += [(a + start, b + start) for a, b in acc]
        rejected += [(a + start, b + start, r) for a, b, r in rej]
        start = end
    return Windows(accepted=accepted, rejected=rejected, tolerances=tol)


def tolerances(speed_rpm, torque_nm, p_elec_w, ranges: dict[str, float],
               config: SteadyConfig) -> dict[str, float]:
    """Tolerance per signal: ``k_tol`` noise sigmas of a bin mean, at least the range floor."""
    return {
        "speed": max(config.k_tol * noise_sigma(speed_rpm), config.floor_frac * ranges["speed"]),
        "torque": max(config.k_tol * noise_sigma(torque_nm), config.floor_frac * ranges["torque"]),
        "power": max(config.k_tol * noise_sigma(p_elec_w), config.floor_frac * ranges["power"]),
    }


def _moving_mask(speed, torque, valid, usable, cuts, tol, lag, config) -> np.ndarray:
    """Bins that belong to no segment: stepping, inside a gap, or not usable."""
    moving = _moving(speed, lag, config.k_step * tol["speed"])
    moving |= _moving(torque, lag, config.k_step * tol["torque"])
    moving |= cuts & ~(valid > 0)  # the empty or all-invalid bins of a gap
    moving |= ~usable
    return moving


def _block_windows(moving, speed, torque, p_elec, valid, cuts, usable, tol, config):
    """Accepted and rejected windows of one block (bin indices within the block)."""
    edges = np.diff(np.concatenate(([1], moving.view(np.int8), [1])))
    starts = np.flatnonzero(edges == -1)
    stops = np.flatnonzero(edges == 1)
    # a gap inside a run of still bins splits it there
    split = np.flatnonzero(cuts[1:] & ~moving[1:] & ~moving[:-1]) + 1
    if split.size:
        starts = np.sort(np.concatenate((starts, split)))
        stops = np.sort(np.concatenate((stops, split)))
    min_bins = _bins(config.min_window_s, config.bin_s)
    report_bins = max(1, _bins(config.min_report_s, config.bin_s))
    keep = stops - starts >= report_bins
    a, b = starts[keep], stops[keep]
    stats = {"speed": _RangeStats(speed), "torque": _RangeStats(torque),
             "power": _RangeStats(p_elec)}
    a = _settle(speed, torque, a, b, tol, stats)
    b = _trim_tail(a, b, stats, tol, max(1, _bins(config.step_lag_s, config.bin_s)))
    reason = _check(stats, _RangeStats(valid), a, b, tol, min_bins, config)
    ok = reason == ""
    accepted = [(int(i), int(j)) for i, j in zip(a[ok], b[ok], strict=True)]
    rejected = [(int(i), int(j), str(r))
                for i, j, r in zip(a[~ok], b[~ok], reason[~ok], strict=True)]
    rejected += _oscillations(starts, stops[keep], starts[keep], stats, tol, min_bins, config)
    lag = max(1, _bins(config.step_lag_s, config.bin_s))
    free = usable & ~(cuts & ~(valid > 0))  # bins a window may cover
    for i, j in _held_stretches(free, accepted, rejected, {"speed": speed, "torque": torque},
                                tol, max(2 * min_bins, 4 * lag + 2), config.k_step):
        why = str(_check(stats, _RangeStats(valid), np.array([i]), np.array([j]), tol, min_bins,
                         config)[0])
        if not why:  # steady as a whole: the detection's own pieces stand
            continue
        rejected = [w for w in rejected if not (w[2] == "too short" and i <= w[0] and w[1] <= j)]
        rejected.append((i, j, why))
    return accepted, _merge_abutting(sorted(rejected))


def held_runs(signals: dict[str, np.ndarray], free: np.ndarray, breaks: np.ndarray,
              tol: dict[str, float], config: SteadyConfig,
              points: list[tuple[int, int]] = ()) -> list[tuple[int, int]]:
    """Stretches of held setpoint among the bins ``free``, as ``(start, stop)`` bins.

    Used for the bins the power analyzer did not record while the DAQ logs a hold, and
    for the analyzer's records where the DAQ logged nothing (``signals`` its power).
    The series are cut where a signal steps (the moving test of step 2 on each of
    ``signals``, tolerances ``tol``) and at ``breaks`` (a gap's empty bins); a still
    run of ``free`` bins is a hold as in step 6 (its transitions trimmed, first and
    last quarter agree) when it is at least ``min_window_s`` long. A stretch whose
    setpoint (the still run around it, ``free`` or not) holds one of ``points`` (the
    accepted windows) is that point's, not a rejected window.
    """
    lag = max(1, _bins(config.step_lag_s, config.bin_s))
    moving = breaks.copy()
    for k, x in signals.items():
        moving |= _moving(x, lag, config.k_step * tol[k])
    stretches = _held_stretches(free & ~moving, [], [], signals, tol,
                                max(1, _bins(config.min_window_s, config.bin_s)),
                                config.k_step)
    run = np.cumsum(moving)  # one id per still run between moving bins
    taken = {int(run[i]) for a, b in points for i in (a, b - 1) if not moving[i]}
    return [(i, j) for i, j in stretches if int(run[i]) not in taken]


def _merge_abutting(rejected: list[tuple[int, int, str]]) -> list[tuple[int, int, str]]:
    """One window for rejected windows that touch and share their reason (sorted input)."""
    out: list[tuple[int, int, str]] = []
    for a, b, why in rejected:
        if out and out[-1][2] == why and out[-1][1] == a:
            out[-1] = (out[-1][0], b, why)
        else:
            out.append((a, b, why))
    return out


def _held_stretches(free, accepted, rejected, signals: dict[str, np.ndarray], tol,
                    min_bins: int, k_step: float) -> list[tuple[int, int]]:
    """Stretches of held setpoint no window covers (step 6), as ``(start, stop)`` bins.

    ``free`` marks the bins a window may cover; bins of accepted windows and of
    rejected windows other than ``too short`` are taken. Each free run loses its
    leading and trailing bins that are off its median speed or torque by more than
    ``k_step`` tolerances (the neighbouring steps' transitions); what is left
    qualifies when it has at least ``min_bins`` bins and the medians of its first
    and last quarter agree within ``k_step`` tolerances in speed and torque.
    """
    taken = np.zeros(free.size + 1, np.int64)
    for a, b, *why in [(a, b) for a, b in accepted] + list(rejected):
        if not why or why[0] != "too short":
            taken[a] += 1
            taken[b] -= 1
    open_ = free & (np.cumsum(taken[:-1]) == 0)
    edges = np.diff(np.concatenate(([0], open_.view(np.int8), [0])))
    out = []
    for i, j in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        if j - i < min_bins:
            continue
        off = np.zeros(j - i, bool)
        for k in signals:
            x = signals[k][i:j]
            off |= np.abs(x - np.nanmedian(x)) > k_step * tol[k]  # NaN (empty bin): not off
        on = np.flatnonzero(~off)
        if on.size == 0:
            continue
        i, j = i + int(on[0]), i + int(on[-1]) + 1
        q = max((j - i) // 4, 1)
        with np.errstate(invalid="ignore"):
            held = all(abs(np.nanmedian(signals[k][i:i + q]) - np.nanmedian(signals[k][j - q:j]))
                       <= k_step * tol[k] for k in signals)
        if j - i >= min_bins and held:
            out.append((int(i), int(j)))
    return out


def _oscillations(piece_starts, seg_stops, seg_starts, stats, tol, min_bins,
                  config) -> list[tuple[int, int, str]]:
    """Stretches between reported segments cut into many unreported pieces (step 5)."""
    g0, g1 = seg_stops[:-1], seg_starts[1:]  # gap k lies between segments k and k + 1
    if g0.size == 0:
        return []
    lo, hi = np.searchsorted(piece_starts, g0, side="right"), np.searchsorted(piece_starts, g1)
    cand = (hi - lo >= config.oscillation_pieces) & (g1 - g0 >= min_bins)
    out = []
    for i, j in zip(g0[cand].tolist(), g1[cand].tolist(), strict=True):
        for key in ("speed", "torque", "power"):
            if stats[key].std(np.array([i]), np.array([j]))[0] > tol[key]:
                out.append((i, j, f"{key} unstable"))
                break
    return out


def _trim_tail(a, b, stats: dict, tol: dict[str, float], m: int) -> np.ndarray:
    """End of each ``[a, b)`` without its last bins (at most ``m``, one ``step_lag_s``) that are
    already off the segment's level in speed, torque or power.

    Below the lag of the step detection the next step may already have begun in
    the last bin (a slow logger, or the analyzer's delay); the level is the mean
    of the segment's second half without those bins.
    """
    b = b.copy()
    for _ in range(m):
        live = b - a > 2 * m
        if not live.any():
            break
        ref_lo = a + (b - a) // 2
        last = b - 1
        off = np.zeros(a.size, bool)
        for key in ("speed", "torque", "power"):
            x = stats[key]
            level = x.mean(ref_lo, np.maximum(b - m, ref_lo + 1))
            here = x.mean(last, b)
            off |= np.abs(here - level) > tol[key]
        cut = live & off
        if not cut.any():
            break
        b[cut] -= 1
    return b


def _settle(speed, torque, a, b, tol: dict[str, float], stats: dict) -> np.ndarray:
    """First bin of each ``[a, b)`` after which speed and torque stay at their final level.

    The final level is the mean of the segment's second half; bins of the first
    half farther from it than the tolerance are still settling.
    """
    if a.size == 0:
        return a
    mid = a + (b - a) // 2
    n = speed.size
    # segment index of every bin in a first half (-1 elsewhere)
    marks = np.zeros(n + 1, np.int64)
    k = np.arange(a.size) + 1
    np.add.at(marks, a, k)
    np.add.at(marks, mid, -k)
    seg = np.cumsum(marks[:-1]) - 1
    inside = seg >= 0
    off = np.zeros(n, dtype=bool)
    for x, key in ((speed, "speed"), (torque, "torque")):
        ref = stats[key].mean(mid, b)
        off[inside] |= np.abs(x[inside] - ref[seg[inside]]) > tol[key]
    last = np.full(a.size, -1, np.int64)
    idx = np.flatnonzero(off)
    np.maximum.at(last, seg[idx], idx)  # last off bin of each segment's first half
    return np.where(last >= 0, last + 1, a)


class _RangeStats:
    """Means, standard deviations and NaN fractions of bin ranges, from cumulative sums."""

    def __init__(self, x: np.ndarray) -> None:
        ok = np.isfinite(x)
        xf = np.where(ok, x, 0.0)
        self.n = np.concatenate(([0], np.cumsum(ok)))
        self.s1 = np.concatenate(([0.0], np.cumsum(xf)))
        self.s2 = np.concatenate(([0.0], np.cumsum(xf * xf)))

    def mean(self, a, b) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return (self.s1[b] - self.s1[a]) / (self.n[b] - self.n[a])

    def std(self, a, b) -> np.ndarray:
        n = self.n[b] - self.n[a]
        with np.errstate(invalid="ignore", divide="ignore"):
            m = (self.s1[b] - self.s1[a]) / n
            return np.sqrt(np.maximum((self.s2[b] - self.s2[a]) / n - m * m, 0.0))

    def nan_frac(self, a, b, base: _RangeStats | None = None) -> np.ndarray:
        """NaN fraction of ``[a, b)``; of the bins finite in ``base`` when given."""
        total = (b - a) if base is None else base.n[b] - base.n[a]
        return 1.0 - (self.n[b] - self.n[a]) / np.maximum(total, 1)


def _bins(seconds: float, bin_s: float) -> int:
    """Bins that cover ``seconds`` (rounded; a hair of float error does not add a bin)."""
    return int(np.ceil(seconds / bin_s - 1e-6))


def _check(stats, valid, a, b, tol, min_bins, config) -> np.ndarray:
    """Rejection reason of each window ``[a, b)`` (``""`` when it is steady); first one wins.

    ``valid`` holds the valid fraction per bin (NaN for empty bins, which do not count).
    """
    with_data = valid.n[b] - valid.n[a]
    tests = [
        ("too short", (b - a < min_bins) | (with_data < config.min_samples)),
        ("invalid samples", (valid.mean(a, b) < 1.0 - config.max_invalid)
         | (stats["power"].nan_frac(a, b, valid) > config.max_invalid)),
    ] + [(f"{key} unstable", ~(stats[key].std(a, b) <= tol[key]))
         for key in ("speed", "torque", "power")]
    reason = np.full(a.size, "", dtype=object)
    for name, bad in reversed(tests):
        reason[bad] = name
    return reason


def quadrant(p_mech_w: np.ndarray) -> np.ndarray:
    """``'motor'`` where the mechanical power is positive, else ``'generator'``."""
    return np.where(np.asarray(p_mech_w) > 0, "motor", "generator")


def why_no_windows(windows: Windows, usable_s: float, duration_s: float, bin_s: float,
                   config: SteadyConfig) -> str:
    """One line saying why a session gave no steady window.

    Parameters
    ----------
    windows : Windows
        The (empty) result of :func:`find_windows`.
    usable_s : float
        Seconds of data a window could cover (after the tare, inside the other
        instrument's record) [s].
    duration_s : float
        Length of the record [s].
    bin_s : float
        Bin width used [s].
    config : SteadyConfig
        The settings used.
    """
    if windows.rejected:
        counts: dict[str, int] = {}
        for _, _, r in windows.rejected:
            counts[r] = counts.get(r, 0) + 1
        listed = ", ".join(f"{r}: {n}" for r, n in sorted(counts.items(), key=lambda x: -x[1]))
        tol = windows.tolerances
        return (f"0 points: all {len(windows.rejected)} candidate windows were rejected "
                f"({listed}; tolerances speed {tol['speed']:.3g} rpm, torque "
                f"{tol['torque']:.3g} N m, power {tol['power']:.3g} W)")
    if usable_s < config.min_window_s:
        return (f"0 points: only {usable_s:.3g} s of the {duration_s:.3g} s record can hold a "
                "window (after the tare, inside the power record)")
    return (f"0 points: no stretch of at least {config.min_window_s:g} s without a setpoint step, "
            f"gap or invalid bin in {usable_s:.4g} s of usable record ({bin_s:.3g} s bins)")
