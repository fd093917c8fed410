"""Cut a cycle-run session into the cycles of its drive profile.

The measured drum speed is matched against the profile's speed set-point: a
cross-correlation over the whole run finds where the profile starts on the DAQ clock,
one per cycle refines each cycle's start, and a straight line through those starts
gives the period and the phase found in the log (not the profile's, which they are
checked against). A cycle the log does not cover, or whose analyzer record has a hole,
or whose speed or torque does not follow the profile, is rejected with its reason.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import signal

from bench.cycle_profile import DriveProfile
from kernel.errors import InputError

#: a run whose speed correlates with the profile's below this is another profile's
MIN_CORRELATION = 0.9
#: a cycle tracks the profile when the rms difference of speed (torque) is below this
#: share of the profile's largest |speed| (torque); a bench of finite bandwidth lags the
#: fast parts of a cycle (the synthetic bench: 4 to 5 % on elec-lim-7.0)
TRACK_RTOL = 0.10
#: a cycle is periodic when its electrical power ends where it started within this share
#: of its largest |p_elec|: not so the cycles next to the ramps, whose start-up or run-out
#: the instruments' lag carries into them (the heating over one cycle moves it 0.2 %)
PERIODIC_RTOL = 0.02
#: the period found may differ from the profile's by this share (clocks differ by ppm)
PERIOD_RTOL = 0.005
#: two clocks (the DAQ's, the bench controller's) agree to this share [-]
CLOCK_RTOL = 1e-4
#: measured over set speed (torque) outside this range: the frame is wrong
GAIN_RANGE = (0.8, 1.25)
#: the drive is at standstill while its speed stays within this share of the profile's
#: largest |speed|; a run whose log ends in a standstill longer than a cycle stopped there
STILL_SHARE = 0.02

SETTLING = "cycle settling"
NOT_LOGGED = "cycle not logged"
NO_ANALYZER = "cycle without analyzer samples"
NOT_TRACKED = "cycle not tracked"
NOT_PERIODIC = "cycle not periodic"


@dataclass(frozen=True)
class CycleCut:
    """Where the profile's cycles lie on the DAQ clock.

    Attributes
    ----------
    phase_s : float
        The DAQ time of cycle 0's start, found [s].
    period_s : float
        The period the cycles are cut with [s]: the one found when it differs from the
        profile's, else the profile's (:func:`_line`).
    correlation : float
        The run's speed against the profile's, at the best shift [-].
    period_found_s, period_found_u_s : float
        The period found from the cycles' starts and its standard uncertainty [s].
    kept : list of int
        The cycles kept.
    rejected : dict
        cycle -> reason (one of :data:`SETTLING`, :data:`NOT_LOGGED`, :data:`NO_ANALYZER`,
        :data:`NOT_PERIODIC`, :data:`NOT_TRACKED`).
    notes : list of str
        One line per rejected cycle saying why in figures.
    tracking : dict
        cycle -> (speed rms difference [rpm], torque rms difference [N m], its start's
        offset from the line through the starts [s]).
    gains : dict
        ``speed`` and ``torque``: measured over set, least squares over the kept cycles.
    """

    phase_s: float
    period_s: float
    correlation: float
    period_found_s: float
    period_found_u_s: float
    kept: list[int] = field(default_factory=list)
    rejected: dict[int, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    tracking: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    gains: dict[str, float] = field(default_factory=dict)

    def bounds(self, k: int) -> tuple[float, float]:
        """Cycle ``k``'s start and end on the DAQ clock [s]."""
        a = self.phase_s + k * self.period_s
        return a, a + self.period_s


def _pearson(x: np.ndarray, y: np.ndarray) -> float:
    x, y = x - x.mean(), y - y.mean()
    d = np.sqrt((x * x).sum() * (y * y).sum())
    return float((x * y).sum() / d) if d > 0 else 0.0


def global_shift(t_bins: np.ndarray, measured: np.ndarray, t_prof: np.ndarray,
                 prof: np.ndarray) -> tuple[float, float]:
    """The DAQ time of the profile's time 0 and the correlation there (FFT
    cross-correlation on the bins' grid)."""
    dt = float(t_bins[1] - t_bins[0])
    grid = np.arange(0.0, t_prof[-1], dt)
    p = np.interp(grid, t_prof, prof)
    m = np.where(np.isfinite(measured), measured, 0.0)
    c = signal.correlate(m - m.mean(), p - p.mean(), mode="full", method="fft")
    lag = int(np.argmax(c)) - (p.size - 1)
    t0 = float(t_bins[0]) + lag * dt
    inside = (t_bins >= t0) & (t_bins <= t0 + t_prof[-1]) & np.isfinite(measured)
    if inside.sum() < 10:
        return t0, 0.0
    return t0, _pearson(measured[inside], np.interp(t_bins[inside] - t0, t_prof, prof))


def _refine(t_bins, measured, template_t, template, guess: float,
            search_s: float) -> tuple[float, float]:
    """The start near ``guess`` [s] at which one cycle of the template fits best, and the
    correlation there: the bins interpolated at the template's times, shifted in steps of
    a bin, then of a twentieth of one around the best, then a parabola through the peak.
    NaN when the log does not hold the cycle (or holds an invalid bin in it)."""
    dt = float(t_bins[1] - t_bins[0])

    def corr(shift: float) -> float:
        t = template_t + guess + shift
        if t[0] < t_bins[0] or t[-1] > t_bins[-1]:
            return -np.inf
        lo, hi = np.searchsorted(t_bins, [t[0], t[-1]])
        if not np.isfinite(measured[max(lo - 1, 0):hi + 1]).all():
            return -np.inf
        return _pearson(np.interp(t, t_bins, measured), template)

    coarse = np.arange(-int(search_s / dt), int(search_s / dt) + 1) * dt
    r = np.array([corr(x) for x in coarse])
    if not np.isfinite(r).any():
        return float("nan"), float("nan")
    fine = coarse[int(np.argmax(r))] + np.arange(-20, 21) * dt / 20
    r = np.array([corr(x) for x in fine])
    best = int(np.argmax(r))
    frac = 0.0
    if 0 < best < r.size - 1 and np.isfinite(r[best - 1:best + 2]).all():
        den = r[best - 1] - 2 * r[best] + r[best + 1]
        frac = 0.5 * (r[best - 1] - r[best + 1]) / den if den < 0 else 0.0
    return guess + fine[best] + frac * dt / 20, float(r[best])


def cycle_starts(t_bins: np.ndarray, speed: np.ndarray, profile: DriveProfile,
                 t0: float) -> tuple[np.ndarray, np.ndarray]:
    """Each cycle's start on the DAQ clock found by its own correlation (NaN where the
    log does not hold it), and that correlation."""
    one = profile.one_cycle()
    speed_set, _ = profile.frame.to_drum(one["speed_set_rpm"], one["torque_set_nm"])
    period, start = profile.period_s, float(profile.header["cycle_start_s"])
    search = min(0.25 * period, 1.0)
    found = np.full(profile.n_cycles, np.nan)
    corr = np.full(profile.n_cycles, np.nan)
    for k in range(profile.n_cycles):
        found[k], corr[k] = _refine(t_bins, speed, one["time_s"], speed_set,
                                    t0 + start + k * period, search)
    return found, corr


def _line(starts: np.ndarray, good: np.ndarray,
          period_prof: float) -> tuple[float, float, float, float]:
    """The line through the good cycles' starts: the phase and the period the cut uses,
    the period found and its standard uncertainty [s].

    The cut uses the period found when it differs from the profile's by more than three
    standard uncertainties and :data:`CLOCK_RTOL` (the DAQ's and the bench controller's
    clocks differ), else the profile's (a period found from a few cycles' starts is good
    to a millisecond, which over a cycle is more than two clocks differ). NaN for the
    found period and its uncertainty when fewer than three cycles were found.
    """
    k = np.flatnonzero(good)
    found, u = float("nan"), float("nan")
    if k.size >= 3:
        (found, _), cov = np.polyfit(k, starts[k], 1, cov=True)
        found, u = float(found), float(np.sqrt(max(cov[0, 0], 0.0)))
    elif k.size == 2:
        found = float((starts[k[1]] - starts[k[0]]) / (k[1] - k[0]))
    period = found if (np.isfinite(u) and abs(found - period_prof)
                       > max(3 * u, CLOCK_RTOL * period_prof)) else period_prof
    phase = float(np.mean(starts[k] - k * period))
    return phase, period, found, u


def _set_on_daq(t: np.ndarray, cut: CycleCut, profile: DriveProfile,
                k: int) -> tuple[np.ndarray, np.ndarray]:
    """The profile's drum-frame set-points at DAQ times ``t`` of cycle ``k``."""
    a, _ = cut.bounds(k)
    tp = (float(profile.header["cycle_start_s"]) + k * profile.period_s
          + (t - a) * profile.period_s / cut.period_s)
    speed, torque = profile.drum()
    return (np.interp(tp, profile.columns["time_s"], speed),
            np.interp(tp, profile.columns["time_s"], torque))


def _gains(bins: dict, cut: CycleCut, profile: DriveProfile) -> dict[str, float]:
    """Measured over set speed and torque: least squares through the origin over the
    cycles the log holds whole."""
    sums = {"speed": [0.0, 0.0], "torque": [0.0, 0.0]}
    for k in range(profile.n_cycles):
        a, b = cut.bounds(k)
        if a < bins["t"][0] or b > bins["t"][-1]:
            continue
        sel = (bins["t"] >= a) & (bins["t"] < b)
        sets = dict(zip(("speed", "torque"), _set_on_daq(bins["t"][sel], cut, profile, k),
                        strict=True))
        ok = np.isfinite(bins["speed"][sel]) & np.isfinite(bins["torque"][sel])
        for q, acc in sums.items():
            acc[0] += float((sets[q][ok] * bins[q][sel][ok]).sum())
            acc[1] += float((sets[q][ok] ** 2).sum())
    return {q: num / den if den > 0 else float("nan") for q, (num, den) in sums.items()}


def _check_gains(gains: dict[str, float], where: dict[str, Path]) -> None:
    """Refuse a log whose speed or torque is a multiple of the profile's: the frame
    (``gear_ratio``, ``measured_side``, the signs) of session.toml does not match it."""
    lo, hi = GAIN_RANGE
    for q, key in (("speed", "speed_sign"), ("torque", "torque_sign")):
        g = gains[q]
        if lo <= g <= hi or not np.isfinite(g):
            continue
        why = (f"the logged {q} of {where['daq'].name} is {g:.3f} x the profile's set-point"
               + (f": its sign is flipped (check {key})" if g < 0 else
                  ": check gear_ratio and measured_side"))
        raise InputError(where["session"], why, column=key if g < 0 else "gear_ratio",
                         expected=f"a log in the frame session.toml states ({q} within "
                         f"{lo:g} to {hi:g} x the profile's)")


def _judge(k: int, cut: CycleCut, sel: np.ndarray, bins: dict, profile: DriveProfile,
           peaks: tuple[float, float], where: dict[str, Path],
           stop: tuple[float, float] | None = None) -> tuple[str | None, str]:
    """Cycle ``k``'s reason to be rejected (None to keep) and the line saying why;
    ``stop``: the time [s] the drive stopped and the end of the log, when it did."""
    a, b = cut.bounds(k)
    if k == 0:
        return SETTLING, (f"cycle 0 ({a:.2f} to {b:.2f} s): the first after the ramp in, "
                          "whose transient the loops' and the instruments' lags carry into it")
    if stop is not None and b > stop[0]:
        return NOT_LOGGED, (f"cycle {k} ({a:.2f} to {b:.2f} s): the drive stopped at "
                            f"{stop[0]:.2f} s ({where['daq'].name}: its speed stays at "
                            f"standstill from there to the end of the log at {stop[1]:.2f} "
                            "s): the run ended early")
    if a < bins["t"][0] or b > bins["t"][-1] or bins["gap"][sel].any() \
            or np.isnan(bins["speed"][sel]).mean() > 0.1:
        return NOT_LOGGED, (f"cycle {k} ({a:.2f} to {b:.2f} s): the log "
                            f"({where['daq'].name}) holds {bins['t'][0]:.2f} to "
                            f"{bins['t'][-1]:.2f} s, with its gaps")
    if not bins["recorded"][sel].all():
        return NO_ANALYZER, (f"cycle {k} ({a:.2f} to {b:.2f} s): the analyzer's record "
                             f"({where.get('analyzer', where['daq']).name}) does not hold it all")
    p = bins["p_elec"]
    ends = np.interp([a, b], bins["t"][np.isfinite(p)], p[np.isfinite(p)])
    peak = float(np.nanmax(np.abs(p[sel])))
    if abs(ends[1] - ends[0]) > PERIODIC_RTOL * peak:
        return NOT_PERIODIC, (f"cycle {k} ({a:.2f} to {b:.2f} s): p_elec ends "
                              f"{ends[1] - ends[0]:+.0f} W from where it started (more than "
                              f"{100 * PERIODIC_RTOL:g} % of its peak {peak:.0f} W): a start-up "
                              "or run-out transient inside it")
    n_set, t_set = _set_on_daq(bins["t"][sel], cut, profile, k)
    rms_n = float(np.sqrt(np.nanmean((bins["speed"][sel] - n_set) ** 2)))
    rms_t = float(np.sqrt(np.nanmean((bins["torque"][sel] - t_set) ** 2)))
    cut.tracking[k] = (rms_n, rms_t, cut.tracking.get(k, (0, 0, float("nan")))[2])
    if rms_n > TRACK_RTOL * peaks[0] or rms_t > TRACK_RTOL * peaks[1]:
        return NOT_TRACKED, (f"cycle {k} ({a:.2f} to {b:.2f} s): off the profile by "
                             f"{rms_n:.1f} rpm and {rms_t:.2f} N m rms (limits "
                             f"{TRACK_RTOL * peaks[0]:.1f} rpm, {TRACK_RTOL * peaks[1]:.2f} N m)")
    return None, ""


def _not_found(problem: str, bins: dict, profile: DriveProfile, where: dict[str, Path],
               t0: float) -> InputError:
    """The error of a run whose cycles cannot be found, saying the likeliest why: a gap in
    the log (its clock jumped, or the logging paused: the time after it does not run with
    the profile's), a log that ends before the first cycle would (the profile starting at
    ``t0`` on the DAQ clock [s]), or else another profile."""
    gap = np.flatnonzero(bins["gap"])
    first = t0 + float(profile.header["cycle_start_s"]) + 2 * profile.period_s
    if gap.size:
        runs = np.split(gap, np.flatnonzero(np.diff(gap) > 1) + 1)
        jumps = ", ".join(f"{bins['t'][r[0]]:.2f} s ({len(r) * (bins['t'][1] - bins['t'][0]):.2f}"
                          " s without samples)" for r in runs[:3])
        return InputError(where["daq"], f"{problem}: the log's time jumps at {jumps}: its "
                          "clock does not run with the profile's across it", column="time",
                          expected="a log whose clock runs without jumps through the profile "
                          "(split the run at the jump, or log it again)")
    if bins["t"][-1] < first:
        return InputError(where["daq"], f"{problem}: the log ends at {bins['t'][-1]:.1f} s, "
                          f"before the profile's cycle 1 would end ({first:.1f} s)",
                          column="time", expected="a log of the whole profile, or of its "
                          "ramp and at least two whole cycles (the first is settling)")
    return InputError(where["profile"], f"{problem}: a different profile than the one "
                      f"named? ({where['daq'].name} against {where['profile'].name})",
                      column="cycle.profile", expected="the drive profile this run flew")


def _stopped(bins: dict, speed_set: np.ndarray, period_s: float) -> tuple[float, float] | None:
    """When the log ends in a standstill longer than a cycle (the drive stopped while the
    loggers ran on): the time it began [s] and the end of the log [s]; else None."""
    moving = np.abs(np.nan_to_num(bins["speed"])) > STILL_SHARE * float(np.abs(speed_set).max())
    if not moving.any():
        return None
    last = int(np.flatnonzero(moving)[-1])
    if last + 1 >= bins["t"].size or bins["t"][-1] - bins["t"][last] <= period_s:
        return None
    return float(bins["t"][last + 1]), float(bins["t"][-1])


def cut_cycles(bins: dict, profile: DriveProfile, where: dict[str, Path]) -> CycleCut:
    """Find the profile's cycles in a run's bins and judge each.

    Parameters
    ----------
    bins : dict of numpy.ndarray
        ``t`` (bin centres, DAQ clock) [s], drum-frame ``speed`` [rpm] and ``torque``
        [N m] (the zero offset off), ``p_elec`` [W], ``recorded`` (the analyzer recorded
        the bin) and ``gap`` (a gap of the logger).
    profile : DriveProfile
        The profile the session names.
    where : dict of Path
        ``session`` (session.toml), ``profile``, ``daq`` and ``analyzer`` (when there is
        one): named in errors and notes.

    Raises
    ------
    InputError
        The speed does not follow the profile, no whole cycle is found or the period
        found (from three cycles or more) is not the profile's: naming the log's time
        jump when it has one, the log when it is too short for a cycle, else the profile
        (another profile); or the log's speed or torque is a multiple of the profile's
        (a wrong frame in session.toml).
    """
    speed_set, torque_set = profile.drum()
    t0, rho = global_shift(bins["t"], bins["speed"], profile.columns["time_s"], speed_set)
    stop = _stopped(bins, speed_set, profile.period_s) if rho < MIN_CORRELATION else None
    if stop is not None:  # a run that stopped early: its cycles up to the stop
        bins = {k: v[bins["t"] < stop[0]] for k, v in bins.items()}
        t0, rho = global_shift(bins["t"], bins["speed"], profile.columns["time_s"], speed_set)
    if rho < MIN_CORRELATION:
        before = "" if stop is None else (f" before the drive stopped at {stop[0]:.2f} s "
                                          "(standstill to the end of the log)")
        raise _not_found(f"the logged speed{before} does not follow this profile (correlation "
                         f"{rho:.2f} at the best shift, below {MIN_CORRELATION:g})", bins,
                         profile, where, t0)
    starts, corr = cycle_starts(bins["t"], bins["speed"], profile, t0)
    good = np.isfinite(starts) & (corr >= MIN_CORRELATION)
    if not good.any():
        raise _not_found("no whole cycle of the profile in the log", bins, profile, where, t0)
    phase, period, found, found_u = _line(starts, good, profile.period_s)
    if np.isfinite(found_u) and abs(found / profile.period_s - 1.0) > PERIOD_RTOL:
        raise _not_found(f"the log's cycles repeat every {found:.4f} s, the profile's every "
                         f"{profile.period_s:.4f} s", bins, profile, where, t0)
    cut = CycleCut(phase, period, rho, found, found_u, tracking={
        k: (np.nan, np.nan, float(starts[k] - phase - k * period)) for k in range(starts.size)})
    cut.gains.update(_gains(bins, cut, profile))
    _check_gains(cut.gains, where)
    peaks = (float(np.abs(speed_set).max()), float(np.abs(torque_set).max()))
    for k in range(profile.n_cycles):
        sel = (bins["t"] >= cut.bounds(k)[0]) & (bins["t"] < cut.bounds(k)[1])
        reason, line = _judge(k, cut, sel, bins, profile, peaks, where, stop)
        if reason is None:
            cut.kept.append(k)
        else:
            cut.rejected[k] = reason
            cut.notes.append(line)
    return cut
