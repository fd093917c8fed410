"""Steady-state windows: settle after each setpoint step, then keep what is stable.

Works on short-bin means (default 0.1 s) of speed, torque and power:

1. Noise per bin of each signal from the median absolute bin-to-bin difference
   (robust: steps are rare). Tolerance = ``k_tol`` noise sigmas, at least a
   small fraction of the sensor's range.
2. A bin is *moving* when the mean of the next ``step_lag_s`` differs from the
   mean of the previous ``step_lag_s`` by more than ``k_step`` tolerances in
   speed or torque. Runs of non-moving bins are the candidate segments, one per setpoint.
3. Settling: the segment starts after the last bin that is off the segment's
   final level (mean of its second half) by more than the tolerance.
4. Checks, in order, each giving a rejection reason: ``too short`` (under
   ``min_window_s``), ``invalid samples`` (more than ``max_invalid`` of the
   samples are NaN), ``speed unstable``, ``torque unstable``, ``power unstable``
   (standard deviation of the bin means above the tolerance).
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
    """

    bin_s: float = 0.1
    step_lag_s: float = 0.5
    min_window_s: float = 2.0
    k_tol: float = 5.0
    k_step: float = 3.0
    floor_frac: float = 0.001
    max_invalid: float = 0.2
    min_report_s: float = 1.0


DEFAULT_STEADY = SteadyConfig()


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
) -> Windows:
    """Find the steady-state window of each setpoint in bin-mean series.

    Parameters
    ----------
    speed_rpm, torque_nm, p_elec_w : array
        Bin means (NaN for empty bins) [rpm, N m, W].
    valid_frac : array
        Fraction of valid samples per bin [-].
    ranges : dict
        Sensor ranges ``speed``, ``torque``, ``power`` [rpm, N m, W] for the tolerance floors.
    config : SteadyConfig, optional
        Detection settings (default :data:`DEFAULT_STEADY`).
    usable : array of bool, optional
        False for bins no window may cover (e.g. outside the analyzer's record).

    Returns
    -------
    Windows
    """
    config = DEFAULT_STEADY if config is None else config
    tol = {
        "speed": max(config.k_tol * noise_sigma(speed_rpm), config.floor_frac * ranges["speed"]),
        "torque": max(config.k_tol * noise_sigma(torque_nm), config.floor_frac * ranges["torque"]),
        "power": max(config.k_tol * noise_sigma(p_elec_w), config.floor_frac * ranges["power"]),
    }
    lag = max(1, int(round(config.step_lag_s / config.bin_s)))
    moving = _moving(speed_rpm, lag, config.k_step * tol["speed"])
    moving |= _moving(torque_nm, lag, config.k_step * tol["torque"])
    moving |= ~np.isfinite(speed_rpm) & (valid_frac == 0)  # empty bins split segments
    if usable is not None:
        moving |= ~usable
    edges = np.diff(np.concatenate(([1], moving.view(np.int8), [1])))
    starts = np.flatnonzero(edges == -1)
    stops = np.flatnonzero(edges == 1)
    min_bins = int(round(config.min_window_s / config.bin_s))
    report_bins = int(round(config.min_report_s / config.bin_s))
    accepted: list[tuple[int, int]] = []
    rejected: list[tuple[int, int, str]] = []
    stds = {"speed": _RangeStd(speed_rpm), "torque": _RangeStd(torque_nm),
            "power": _RangeStd(p_elec_w)}
    cum_valid = np.concatenate(([0.0], np.cumsum(valid_frac)))
    for a, b in zip(starts, stops, strict=True):
        if b - a < report_bins:
            continue
        a = _settle(speed_rpm, torque_nm, a, b, tol, stds)
        reason = _check(stds, cum_valid, a, b, tol, min_bins, config)
        if reason is None:
            accepted.append((int(a), int(b)))
        else:
            rejected.append((int(a), int(b), reason))
    return Windows(accepted=accepted, rejected=rejected, tolerances=tol)


def _settle(speed, torque, a: int, b: int, tol: dict[str, float], stds: dict) -> int:
    """First bin of ``[a, b)`` after which speed and torque stay at their final level.

    The final level is the mean of the segment's second half.
    """
    mid = a + (b - a) // 2
    off = np.zeros(mid - a, dtype=bool)
    for x, key in ((speed, "speed"), (torque, "torque")):
        off |= np.abs(x[a:mid] - stds[key].mean(mid, b)) > tol[key]
    bad = np.flatnonzero(off)
    return a + int(bad[-1]) + 1 if bad.size else a


class _RangeStd:
    """Standard deviation and NaN fraction of any bin range in O(1), from cumulative sums."""

    def __init__(self, x: np.ndarray) -> None:
        ok = np.isfinite(x)
        xf = np.where(ok, x, 0.0)
        self.n = np.concatenate(([0], np.cumsum(ok)))
        self.s1 = np.concatenate(([0.0], np.cumsum(xf)))
        self.s2 = np.concatenate(([0.0], np.cumsum(xf * xf)))

    def mean(self, a: int, b: int) -> float:
        n = self.n[b] - self.n[a]
        return float((self.s1[b] - self.s1[a]) / n) if n else float("nan")

    def std(self, a: int, b: int) -> float:
        n = self.n[b] - self.n[a]
        if n == 0:
            return float("nan")
        m = (self.s1[b] - self.s1[a]) / n
        return float(np.sqrt(max((self.s2[b] - self.s2[a]) / n - m * m, 0.0)))

    def nan_frac(self, a: int, b: int) -> float:
        return 1.0 - (self.n[b] - self.n[a]) / (b - a)


def _check(stds, cum_valid, a, b, tol, min_bins, config) -> str | None:
    """Rejection reason of window ``[a, b)``, or None when it is steady."""
    if b - a < min_bins:
        return "too short"
    if (cum_valid[b] - cum_valid[a]) / (b - a) < 1.0 - config.max_invalid or (
        stds["power"].nan_frac(a, b) > config.max_invalid
    ):
        return "invalid samples"
    for key in ("speed", "torque", "power"):
        if stds[key].std(a, b) > tol[key]:
            return f"{key} unstable"
    return None


def quadrant(p_mech_w: np.ndarray) -> np.ndarray:
    """``'motor'`` where the mechanical power is positive, else ``'generator'``."""
    return np.where(np.asarray(p_mech_w) > 0, "motor", "generator")
