"""Put the power analyzer on the DAQ clock: clock offset, drift and an as-of join.

The two instruments run on their own clocks. The header start times give a
prior offset; the data refine it: the DAQ's mechanical power ``speed*torque``
and the analyzer's electrical power step together at every setpoint change,
so the lag that maximises the cross-correlation of their increments (on a
common grid; then refined continuously by re-interpolating the analyzer at
sub-sample shifts) is the residual offset. The
same estimate in consecutive segments of the session, fitted with a straight
line, gives the drift and its standard uncertainty (from the line's residuals, at
least that of segment offsets good to a tenth of a grid step). Where the estimate
is not above twice its uncertainty (not significant at about 95 %; a slow logger:
at 1 Hz a drift of tens of ppm over minutes is milliseconds, far below what the
data resolve), the model falls back to the offset alone and says so.

Clock model: ``t_daq = offset_s + (1 + drift_ppm * 1e-6) * t_analyzer``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: largest residual offset searched around the header prior [s]
MAX_LAG_S = 20.0
#: shortest session whose drift is estimated; shorter ones get drift 0 (tens of ppm
#: over a few minutes are a few ms, below what the 0.1 s grid resolves) [s]
MIN_DRIFT_SPAN_S = 300.0
#: segments whose offsets a straight line is fitted through for the drift [-]
DRIFT_SEGMENTS = 8
#: longest stretch of data one offset estimate uses [s]
SEGMENT_SPAN_S = 1200.0
#: smallest |correlation| of a segment estimate that is trusted for the drift [-]
MIN_HALF_CORRELATION = 0.5
#: standard uncertainty of one segment offset, at least this fraction of the grid step
#: (the sub-sample refinement is good to ~5-10 ms on a 0.1 s grid) [-]
OFFSET_FLOOR_STEPS = 0.1
#: a drift is applied only when it exceeds this many of its standard uncertainties [-]
DRIFT_SIGMAS = 2.0


@dataclass(frozen=True)
class ClockModel:
    """Affine map from the analyzer clock to the DAQ clock.

    Parameters
    ----------
    offset_s : float
        DAQ time at analyzer time 0 [s].
    drift_ppm : float
        Rate difference, ``(d t_daq / d t_analyzer - 1) * 1e6`` [ppm].
    prior_offset_s : float
        The offset the header start times alone give [s].
    correlation : float
        Normalised cross-correlation at the peak (sign included; near -1 means
        the mechanical power has the wrong sign) [-].
    drift_estimate_ppm, drift_uncertainty_ppm : float
        The drift the segment offsets give and its standard uncertainty [ppm]
        (NaN when the session is too short to estimate a drift).
    drift_note : str or None
        Why ``drift_ppm`` is 0 although a drift was estimated (the estimate is not
        above :data:`DRIFT_SIGMAS` uncertainties: offset only), else None.
    """

    offset_s: float
    drift_ppm: float
    prior_offset_s: float
    correlation: float
    drift_estimate_ppm: float = float("nan")
    drift_uncertainty_ppm: float = float("nan")
    drift_note: str | None = None

    def to_daq(self, t_analyzer_s: np.ndarray) -> np.ndarray:
        """Analyzer times [s] -> DAQ times [s]."""
        return self.offset_s + (1.0 + self.drift_ppm * 1e-6) * np.asarray(t_analyzer_s)


def _grid_search(cost, centre: float, half_width: float) -> float:
    """Minimise a 1-D cost on ``centre +- half_width``: a coarse grid, a fine grid around its
    best point, then a parabola through the fine minimum and its neighbours."""
    for n in (7, 11):
        xs = np.linspace(centre - half_width, centre + half_width, n)
        cs = np.array([cost(x) for x in xs])
        k = int(np.argmin(cs))
        centre, half_width = float(xs[k]), float(xs[1] - xs[0])
    if 0 < k < n - 1:
        den = cs[k - 1] - 2.0 * cs[k] + cs[k + 1]
        if den > 0:
            centre += 0.5 * half_width * (cs[k - 1] - cs[k + 1]) / den
    return centre


def _increments(x: np.ndarray) -> np.ndarray:
    d = np.diff(x)
    d[~np.isfinite(d)] = 0.0
    return d


def _peak_lag(x: np.ndarray, y: np.ndarray, dt: float, max_lag: float) -> tuple[float, float]:
    """Lag [s] by which ``y`` must be delayed to match ``x``, and the peak correlation.

    Both series are on the same grid of step ``dt`` [s]; the search spans
    ``[-max_lag, max_lag]``; the peak is refined by a parabola through its neighbours.
    """
    dx, dy = _increments(x), _increments(y)
    norm = float(np.sqrt(np.sum(dx * dx) * np.sum(dy * dy)))
    if norm == 0.0:
        return 0.0, 0.0
    # full cross-correlation via FFT: c[lag] = sum_n dx[n + lag] * dy[n]
    n = dx.size + dy.size - 1
    nfft = 1 << (n - 1).bit_length()
    full = np.fft.irfft(np.fft.rfft(dx, nfft) * np.conj(np.fft.rfft(dy, nfft)), nfft)
    k_max = min(int(round(max_lag / dt)), dx.size - 1, dy.size - 1)
    lags = np.arange(-k_max, k_max + 1)
    c = full[lags % nfft] / norm
    k = int(np.argmax(np.abs(c)))
    frac = 0.0
    if 0 < k < c.size - 1:
        y0, y1, y2 = np.abs(c[k - 1]), np.abs(c[k]), np.abs(c[k + 1])
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            frac = 0.5 * (y0 - y2) / den
    return (lags[k] + frac) * dt, float(c[k])


def estimate_clock(
    grid_t_s: np.ndarray,
    p_mech_w: np.ndarray,
    analyzer_t_s: np.ndarray,
    p_elec_w: np.ndarray,
    prior_offset_s: float,
    max_lag_s: float = MAX_LAG_S,
) -> ClockModel:
    """Estimate the analyzer->DAQ clock offset and drift from the data.

    Parameters
    ----------
    grid_t_s : array
        Uniform grid on the DAQ clock [s] (bin centres).
    p_mech_w : array
        DAQ mechanical power averaged on that grid [W] (NaN for empty bins).
    analyzer_t_s, p_elec_w : array
        Analyzer time on its own clock [s] and electrical power [W].
    prior_offset_s : float
        Analyzer start minus DAQ start from the file headers [s].
    max_lag_s : float
        Search span around the prior [s].

    Returns
    -------
    ClockModel
    """
    dt = float(grid_t_s[1] - grid_t_s[0])
    match = _PowerMatch(grid_t_s, p_mech_w, analyzer_t_s, p_elec_w)
    # global offset from the first SEGMENT_SPAN_S (cost independent of session length)
    first = slice(0, int(SEGMENT_SPAN_S / dt))
    lag, corr = _peak_lag(match.pm[first], _fill(match.on_grid(prior_offset_s,
                                                                 grid_t_s[first])), dt,
                          max_lag_s)
    offset = match.refine(prior_offset_s + lag, first)
    centres, offsets = _segment_offsets(match, offset, max_lag_s)
    slope, estimate, sigma, note = 0.0, np.nan, np.nan, None
    if len(offsets) >= 2:
        span = float(grid_t_s[-1] - grid_t_s[0])
        estimate, line_offset, sigma = drift_line(centres, offsets, OFFSET_FLOOR_STEPS * dt)
        if DRIFT_SIGMAS * sigma < abs(estimate):
            slope, offset = estimate, line_offset
        else:  # not resolved: the offset alone, the mean of the segment offsets
            offset = float(np.mean(offsets))
            note = (f"clock drift {estimate * 1e6:+.1f} +- {sigma * 1e6:.1f} ppm (1 sigma) not "
                    f"resolved on a {dt:g} s grid over {span:.0f} s (below "
                    f"{DRIFT_SIGMAS:g} sigma): offset only, drift 0")
    return ClockModel(
        offset_s=float(offset), drift_ppm=float(slope * 1e6),
        prior_offset_s=float(prior_offset_s), correlation=corr,
        drift_estimate_ppm=float(estimate * 1e6), drift_uncertainty_ppm=float(sigma * 1e6),
        drift_note=note,
    )


class _PowerMatch:
    """The DAQ's mechanical power on its grid against the analyzer's electrical power
    moved onto that grid by a clock offset."""

    def __init__(self, grid_t_s: np.ndarray, p_mech_w: np.ndarray, analyzer_t_s: np.ndarray,
                 p_elec_w: np.ndarray) -> None:
        self.grid_t_s = grid_t_s
        self.dt = float(grid_t_s[1] - grid_t_s[0])
        ok = np.isfinite(p_elec_w)
        self.ta, self.pa = analyzer_t_s[ok], p_elec_w[ok]
        self.pm = _fill(p_mech_w)

    def on_grid(self, offset: float, t: np.ndarray) -> np.ndarray:
        """The analyzer's power at DAQ times ``t`` [s] for a clock offset [s]."""
        return np.interp(t - offset, self.ta, self.pa, left=np.nan, right=np.nan)

    def refine(self, guess: float, sl: slice) -> float:
        """Maximise |corr| over a continuous offset within a grid step of ``guess`` on the
        grid slice ``sl``."""
        t, dx = self.grid_t_s[sl], _increments(self.pm[sl])

        def cost(off: float) -> float:
            dy = _increments(_fill(self.on_grid(off, t)))
            # plain sums, not BLAS dot: no thread pool spin-up on a busy machine
            return -abs(float(np.sum(dx * dy)) / (float(np.sqrt(np.sum(dy * dy))) or 1.0))

        return _grid_search(cost, guess, 1.5 * self.dt)


def _segment_offsets(match: _PowerMatch, offset: float,
                     max_lag_s: float) -> tuple[list[float], list[float]]:
    """The offset in :data:`DRIFT_SEGMENTS` segments (their central SEGMENT_SPAN_S): their
    centres on the analyzer clock and offsets [s].

    Each segment is searched around the offset the segments before it predict (drift
    over a long session adds up to seconds); a straight line through them gives offset
    and drift. A segment whose correlation is below :data:`MIN_HALF_CORRELATION` is left
    out.
    """
    grid_t_s, dt = match.grid_t_s, match.dt
    span = float(grid_t_s[-1] - grid_t_s[0]) if grid_t_s.size else 0.0
    n_seg = int(min(DRIFT_SEGMENTS, span // (MIN_DRIFT_SPAN_S / 2)))
    half = int(SEGMENT_SPAN_S / dt) // 2
    centres, offsets = [], []
    for idx in np.array_split(np.arange(grid_t_s.size), n_seg) if n_seg >= 2 else []:
        mid = int(idx[idx.size // 2])
        sl = slice(max(int(idx[0]), mid - half), min(int(idx[-1]) + 1, mid + half))
        t = grid_t_s[sl]
        t_a = float(np.mean(t)) - offset  # on the analyzer clock
        guess = offset if len(offsets) < 2 else float(np.polyval(
            np.polyfit(centres, offsets, 1), t_a))
        lag_h, corr_h = _peak_lag(match.pm[sl], _fill(match.on_grid(guess, t)), dt,
                                  min(2.0, max_lag_s))
        if abs(corr_h) < MIN_HALF_CORRELATION:
            continue
        centres.append(t_a)
        offsets.append(match.refine(guess + lag_h, sl))
    return centres, offsets


def drift_line(t_s, offsets_s, floor_s: float) -> tuple[float, float, float]:
    """Straight line through segment offsets: slope, intercept and the slope's standard error.

    Parameters
    ----------
    t_s, offsets_s : sequence of float
        Segment centres on the analyzer clock and their offsets [s] (at least 2).
    floor_s : float
        Smallest standard uncertainty of one offset [s].

    Returns
    -------
    slope : float
        Drift [s/s].
    intercept : float
        Offset at analyzer time 0 [s].
    sigma : float
        Standard error of the slope [s/s]: ``s / sqrt(Sxx)`` with ``s`` the larger
        of the residual standard deviation (``n - 2`` degrees of freedom, when
        ``n >= 3``) and ``floor_s``.
    """
    x, y = np.asarray(t_s, float), np.asarray(offsets_s, float)
    slope, intercept = np.polyfit(x, y, 1)
    sxx = float(np.sum((x - x.mean()) ** 2))
    s2 = floor_s**2
    if x.size >= 3:
        s2 = max(s2, float(np.sum((y - (slope * x + intercept)) ** 2)) / (x.size - 2))
    sigma = float(np.sqrt(s2 / sxx)) if sxx > 0 else float("inf")
    return float(slope), float(intercept), sigma


def _fill(x: np.ndarray) -> np.ndarray:
    """Hold the last finite value over NaN gaps (leading NaN take the first value)."""
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x)
    if not ok.any():
        return np.zeros_like(x)
    idx = np.where(ok, np.arange(x.size), 0)
    np.maximum.accumulate(idx, out=idx)
    out = x[idx]
    out[: np.argmax(ok)] = x[np.argmax(ok)]
    return out


def asof_nearest(
    t_query_s: np.ndarray, t_ref_s: np.ndarray, values: np.ndarray, tolerance_s: float
) -> np.ndarray:
    """As-of join on sorted arrays: the value of the nearest reference time within tolerance.

    Parameters
    ----------
    t_query_s : array
        Sorted query times [s] (DAQ samples).
    t_ref_s : array
        Sorted reference times [s] (analyzer samples, already on the DAQ clock).
    values : array
        Reference values (NaN kept).
    tolerance_s : float
        Largest accepted distance [s]; farther queries get NaN.

    Returns
    -------
    array
        One value per query.
    """
    n = t_query_s.size
    if t_ref_s.size == 0 or n == 0:
        return np.full(n, np.nan)
    # only the references near this block of queries matter
    lo = max(int(np.searchsorted(t_ref_s, t_query_s[0])) - 1, 0)
    hi = int(np.searchsorted(t_ref_s, t_query_s[-1])) + 1
    t_ref_s, values = t_ref_s[lo:hi], values[lo:hi]
    # each reference sample owns the queries between the midpoints to its neighbours;
    # searching the few midpoints in the many queries is O(n_ref log n)
    cuts = np.searchsorted(t_query_s, 0.5 * (t_ref_s[1:] + t_ref_s[:-1]))
    pick = np.repeat(np.arange(t_ref_s.size), np.diff(np.concatenate(([0], cuts, [n]))))
    out = values[pick]
    out[np.abs(t_ref_s[pick] - t_query_s) > tolerance_s] = np.nan
    return out
