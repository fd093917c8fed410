"""Wind-speed distributions of a site: Weibull, Rayleigh, or a measured histogram.

Every distribution answers two questions on wind speed ``v`` [m/s] at the
system's reference height (the height of the optimize stage's wind speeds,
100 m for today's kite model):

* ``cdf(v)``: the probability that the wind is below ``v``;
* ``partial_mean(v)``: ``M(v) = integral_0^v u f(u) du`` [m/s], the first
  partial moment;
* ``partial_cube(v)``: ``integral_0^v u^3 f(u) du`` [m^3/s^3], the third partial moment:
  the wind's available energy (power density ``rho v^3 / 2``) below ``v``, so
  :func:`energy_share` is the share of the site's available wind energy between two speeds.

With both, the energy of a piecewise-linear power curve is exact (see
:func:`energy.aep.expected_power_w`): on a segment ``[a, b]`` where
``P(v) = alpha + beta v``, ``integral P f dv = alpha (F(b) - F(a)) + beta (M(b) - M(a))``.

A site given at another height is moved to the reference height with the
logarithmic profile ``v(h) ~ ln(h / z0)`` (roughness length ``z0``): a Weibull
scale scales by the ratio, the shape is unchanged; a histogram's bin speeds
scale by it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import special

from kernel.errors import InputError
from kernel.files import read_text

#: hours in a (non-leap) year: the AEP convention of IEC 61400-12-1
HOURS_PER_YEAR = 8760.0
#: Weibull shapes whose integrals stay finite in double precision (the gamma function of
#: 1 + 1/k overflows below the first, the powers (v/c)^k above the second)
WEIBULL_K_NUMERIC = (0.1, 100.0)


def _check_shape(k: float) -> None:
    """Raise ValueError for a Weibull shape outside :data:`WEIBULL_K_NUMERIC`."""
    lo, hi = WEIBULL_K_NUMERIC
    if not (math.isfinite(k) and lo <= k <= hi):
        raise ValueError(f"Weibull shape k must be from {lo:g} to {hi:g} (beyond, its "
                         f"integrals overflow), got {k}")


@dataclass(frozen=True)
class Shear:
    """The wind profile that relates wind speeds at two heights (the system's ``[wind]``).

    Attributes
    ----------
    reference_height_m : float
        Height of the optimize stage's wind speeds [m].
    profile_kind : str
        ``"log"``: ``v(h) ~ ln((h + z0) / z0)``, the kite model's (docs/system_file.md);
        ``"power"``: ``v(h) ~ h^exponent``.
    roughness_m : float or None
        Roughness length ``z0`` [m] (log profile).
    exponent : float or None
        Shear exponent [-] (power profile).
    """

    reference_height_m: float = 100.0
    profile_kind: str = "log"
    roughness_m: float | None = 0.1
    exponent: float | None = None

    @classmethod
    def from_system(cls, wind) -> Shear:
        """From a system file's ``[wind]`` section (``optimize.system.system.WindSection``)."""
        return cls(wind.reference_height_m, wind.profile, wind.roughness_length_m, wind.exponent)

    def describe(self) -> str:
        """One line: the profile and its parameter."""
        if self.profile_kind == "log":
            return f"logarithmic shear z0 = {self.roughness_m:g} m"
        return f"power-law shear exponent {self.exponent:g}"

    def profile(self, height_m: float) -> float:
        """``v(h) / v_ref``: the wind at ``height_m`` per unit of the optimize stage's wind
        speed [-], exactly as the kite model computes it (optimize.model.aero.wind_speed).

        Raises
        ------
        ValueError
            A height at or below ground.
        """
        if not height_m > 0:
            raise ValueError(f"height {height_m} m must be above ground (> 0)")
        if self.profile_kind == "log":
            z0 = self.roughness_m
            return math.log((height_m + z0) / z0) / math.log(self.reference_height_m / z0)
        return (height_m / self.reference_height_m) ** self.exponent


@dataclass(frozen=True)
class Weibull:
    """Weibull distribution ``F(v) = 1 - exp(-(v / c)^k)``.

    Parameters
    ----------
    k : float
        Shape [-], > 0.
    scale_m_s : float
        Scale ``c`` [m/s], > 0.
    """

    k: float
    scale_m_s: float

    def __post_init__(self) -> None:
        _check_shape(self.k)
        if not (math.isfinite(self.scale_m_s) and self.scale_m_s > 0):
            raise ValueError(f"Weibull scale must be finite and > 0 m/s, got {self.scale_m_s}")

    @classmethod
    def from_mean(cls, k: float, mean_m_s: float) -> Weibull:
        """Weibull of shape ``k`` with mean ``mean_m_s`` [m/s]: ``c = mean / Gamma(1 + 1/k)``."""
        _check_shape(k)
        return cls(k, mean_m_s / math.gamma(1.0 + 1.0 / k))

    @property
    def mean_m_s(self) -> float:
        """Mean wind speed [m/s]."""
        return self.scale_m_s * math.gamma(1.0 + 1.0 / self.k)

    def cdf(self, v: np.ndarray) -> np.ndarray:
        """Probability that the wind is below ``v`` [m/s]."""
        v = np.clip(np.asarray(v, dtype=float), 0.0, None)
        return -np.expm1(-((v / self.scale_m_s) ** self.k))

    def partial_mean(self, v: np.ndarray) -> np.ndarray:
        """``integral_0^v u f(u) du`` [m/s] = ``c Gamma(1 + 1/k) P(1 + 1/k, (v/c)^k)``."""
        v = np.clip(np.asarray(v, dtype=float), 0.0, None)
        a = 1.0 + 1.0 / self.k
        return self.mean_m_s * special.gammainc(a, (v / self.scale_m_s) ** self.k)

    def partial_cube(self, v: np.ndarray) -> np.ndarray:
        """``integral_0^v u^3 f(u) du`` [m^3/s^3] = ``c^3 Gamma(1 + 3/k) P(1 + 3/k, (v/c)^k)``."""
        v = np.clip(np.asarray(v, dtype=float), 0.0, None)
        a = 1.0 + 3.0 / self.k
        return self.scale_m_s**3 * math.gamma(a) * special.gammainc(a, (v / self.scale_m_s)
                                                                     ** self.k)

    def quantile(self, share: float) -> float:
        """The wind speed [m/s] below which ``share`` of the hours lie: ``c (-ln(1 - q))^(1/k)``."""
        return self.scale_m_s * (-math.log1p(-share)) ** (1.0 / self.k)

    def scaled(self, factor: float) -> Weibull:
        """The distribution of ``factor * v`` (a height change): same shape, scale times factor."""
        return Weibull(self.k, self.scale_m_s * factor)

    def describe(self) -> str:
        """One line for reports."""
        return (f"Weibull k = {self.k:g}, scale {self.scale_m_s:.3f} m/s "
                f"(mean {self.mean_m_s:.3f} m/s)")

    def to_dict(self) -> dict:
        """JSON-ready description."""
        return {"type": "weibull", "k": self.k, "scale_m_s": self.scale_m_s,
                "mean_m_s": self.mean_m_s}


def rayleigh(mean_m_s: float) -> Weibull:
    """Rayleigh distribution of mean ``mean_m_s`` [m/s]: Weibull k = 2, ``c = 2 mean/sqrt(pi)``."""
    return Weibull(2.0, 2.0 * mean_m_s / math.sqrt(math.pi))


@dataclass(frozen=True)
class Histogram:
    """A measured wind-speed histogram: probability spread uniformly inside each bin.

    Parameters
    ----------
    edges_m_s : tuple of float
        Bin edges [m/s], strictly increasing, the first >= 0 (n + 1 values).
    probabilities : tuple of float
        Probability of each bin (n values, >= 0, summing to 1).
    """

    edges_m_s: tuple[float, ...]
    probabilities: tuple[float, ...]

    def __post_init__(self) -> None:
        e, p = np.asarray(self.edges_m_s, float), np.asarray(self.probabilities, float)
        if e.ndim != 1 or len(e) < 2 or len(p) != len(e) - 1:
            raise ValueError("a histogram needs n + 1 edges for n >= 1 probabilities")
        if not (np.all(np.isfinite(e)) and e[0] >= 0 and np.all(np.diff(e) > 0)):
            raise ValueError("histogram edges must be finite, >= 0 and strictly increasing")
        if not (np.all(np.isfinite(p)) and np.all(p >= 0) and abs(p.sum() - 1.0) < 1e-9):
            raise ValueError("histogram probabilities must be >= 0 and sum to 1")

    @property
    def mean_m_s(self) -> float:
        """Mean wind speed [m/s]."""
        e, p = np.asarray(self.edges_m_s), np.asarray(self.probabilities)
        return float(np.sum(p * 0.5 * (e[1:] + e[:-1])))

    def cdf(self, v: np.ndarray) -> np.ndarray:
        """Probability that the wind is below ``v`` [m/s] (linear inside a bin)."""
        e = np.asarray(self.edges_m_s)
        cum = np.concatenate([[0.0], np.cumsum(self.probabilities)])
        return np.interp(np.asarray(v, dtype=float), e, cum, left=0.0, right=1.0)

    def partial_mean(self, v: np.ndarray) -> np.ndarray:
        """``integral_0^v u f(u) du`` [m/s] with ``f`` constant inside each bin."""
        e, p = np.asarray(self.edges_m_s), np.asarray(self.probabilities)
        v = np.asarray(v, dtype=float)
        lo = np.clip(v[..., None], e[:-1], e[1:])  # the part of each bin below v
        density = p / np.diff(e)
        return np.sum(density * 0.5 * (lo**2 - e[:-1] ** 2), axis=-1)

    def partial_cube(self, v: np.ndarray) -> np.ndarray:
        """``integral_0^v u^3 f(u) du`` [m^3/s^3] with ``f`` constant inside each bin."""
        e, p = np.asarray(self.edges_m_s), np.asarray(self.probabilities)
        v = np.asarray(v, dtype=float)
        lo = np.clip(v[..., None], e[:-1], e[1:])
        density = p / np.diff(e)
        return np.sum(density * 0.25 * (lo**4 - e[:-1] ** 4), axis=-1)

    def quantile(self, share: float) -> float:
        """The wind speed [m/s] below which ``share`` of the hours lie (linear inside a bin)."""
        e = np.asarray(self.edges_m_s)
        cum = np.concatenate([[0.0], np.cumsum(self.probabilities)])
        i = int(np.clip(np.searchsorted(cum, share, side="left"), 1, len(e) - 1))
        p = cum[i] - cum[i - 1]  # > 0: the first bin whose cumulative share reaches ``share``
        return float(e[i - 1] + (e[i] - e[i - 1]) * (share - cum[i - 1]) / p)

    def scaled(self, factor: float) -> Histogram:
        """The distribution of ``factor * v``: every edge times ``factor``."""
        return Histogram(tuple(float(x) * factor for x in self.edges_m_s), self.probabilities)

    def describe(self) -> str:
        """One line for reports."""
        e = self.edges_m_s
        return (f"histogram, {len(self.probabilities)} bins {e[0]:g}-{e[-1]:g} m/s "
                f"(mean {self.mean_m_s:.3f} m/s)")

    def to_dict(self) -> dict:
        """JSON-ready description."""
        return {"type": "histogram", "edges_m_s": list(self.edges_m_s),
                "probabilities": list(self.probabilities), "mean_m_s": self.mean_m_s}


Distribution = Weibull | Histogram


def site_from_dict(record: dict) -> Distribution:
    """The distribution a ``to_dict`` record describes (``aep.json``, ``sizing.json``).

    Raises
    ------
    ValueError
        A record of another type, or values that make no distribution.
    """
    if record.get("type") == "weibull":
        return Weibull(float(record["k"]), float(record["scale_m_s"]))
    if record.get("type") == "histogram":
        return Histogram(tuple(record["edges_m_s"]), tuple(record["probabilities"]))
    raise ValueError(f"site type {record.get('type')!r}: 'weibull' or 'histogram' expected")

#: the share of the site's available wind energy a grid that "covers the site" may leave
#: out above its last speed (:func:`covering_stop`): it holds 99 % of the energy the wind
#: brings from its first speed up
ENERGY_LEFT_OUT = 0.01


def energy_share(dist: Distribution, lo_m_s: float, hi_m_s: float = math.inf) -> float:
    """The share of the site's available wind energy (``rho v^3 / 2`` over the year) in
    the wind from ``lo_m_s`` to ``hi_m_s`` [m/s] (default: no upper end) [-]."""
    top = _top(dist)
    hi = min(hi_m_s, top)
    return float(dist.partial_cube(hi) - dist.partial_cube(lo_m_s)) / float(
        dist.partial_cube(top))


def _top(dist: Distribution) -> float:
    """A speed above which the distribution holds no energy worth counting [m/s]."""
    if isinstance(dist, Histogram):
        return float(dist.edges_m_s[-1])
    return dist.quantile(1.0 - 1e-15) * 1.5


def energy_quantile(dist: Distribution, share: float) -> float:
    """The wind speed [m/s] below which ``share`` of the site's available wind energy lies."""
    from scipy.optimize import brentq

    if not 0 < share < 1:
        raise ValueError(f"an energy share in (0, 1), got {share}")
    return float(brentq(lambda v: energy_share(dist, 0.0, v) - share, 0.0, _top(dist),
                        xtol=1e-9))


def covering_stop(dist: Distribution, start_m_s: float, step_m_s: float,
                  left_out: float = ENERGY_LEFT_OUT, ceiling_m_s: float | None = None) -> float:
    """The last speed of the grid ``start, start + step, ...`` that covers the site [m/s].

    The first grid speed at or above the one above which less than ``left_out`` of the
    site's available wind energy lies (:func:`energy_quantile`), at least ``start + step``
    (two speeds), and not above ``ceiling_m_s`` (a cut-out) when given: the grid then ends
    at the last speed at or below it.

    Parameters
    ----------
    dist : Weibull or Histogram
        Site at the grid's reference height.
    start_m_s, step_m_s : float
        First speed and spacing of the grid [m/s], ``step_m_s > 0``.
    left_out : float
        Share of the available wind energy the grid may leave above its end, in (0, 1).
    ceiling_m_s : float, optional
        Highest speed worth solving [m/s].
    """
    if not (step_m_s > 0 and 0 < left_out < 1):
        raise ValueError(f"need step > 0 and a share in (0, 1), got {step_m_s}, {left_out}")
    top = energy_quantile(dist, 1.0 - left_out)
    n = max(1, math.ceil((top - start_m_s) / step_m_s - 1e-9))
    if ceiling_m_s is not None:
        n = max(1, min(n, math.floor((ceiling_m_s - start_m_s) / step_m_s + 1e-9)))
    return start_m_s + n * step_m_s

_SPEED_COLUMNS = {
    "edges": ("v_low_m_s", "v_high_m_s"),
    "centres": ("v_m_s",),
}
_WEIGHT_COLUMNS = ("hours", "probability")
_HISTOGRAM_EXPECTED = (
    "a CSV with a header row: either 'v_low_m_s,v_high_m_s' (bin edges) or 'v_m_s' (bin "
    "centres, evenly spaced or not: edges at the midpoints), and one of 'hours' or "
    "'probability'; '#' lines are comments"
)


def read_histogram_csv(path: str | Path) -> Histogram:
    """Read a wind-speed histogram CSV (docs/schemas.md §7).

    Columns: ``v_low_m_s, v_high_m_s`` (bin edges, adjacent bins must share
    their edge) or ``v_m_s`` (bin centres; the edges are the midpoints between
    centres, the outer edges half a spacing out, clipped at 0); and ``hours`` or
    ``probability`` per bin. Hours are normalised by their sum; probabilities
    must sum to 1 within 1 %, and are then normalised.

    Raises
    ------
    InputError
        Naming the file, line and column of the first bad value.
    """
    path = Path(path)
    text = read_text(path, what="histogram file")
    rows = [(n, line) for n, line in enumerate(text.splitlines(), 1)
            if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise InputError(path, "no header row", expected=_HISTOGRAM_EXPECTED)
    speed_cols, weight = _histogram_header(path, *rows[0])
    values, lines = _histogram_values(path, rows, (*speed_cols, weight))
    if speed_cols == _SPEED_COLUMNS["edges"]:
        edges = _edges_of_bins(path, values, lines)
    else:
        edges = _edges_of_centres(path, values, lines)
    w = np.array(values[weight])
    total = w.sum()
    if total <= 0:
        raise InputError(path, f"the {weight} sum to 0", column=weight,
                         expected="some positive weight")
    if weight == "probability" and abs(total - 1.0) > 0.01:
        raise InputError(path, f"probabilities sum to {total:.4f}", column="probability",
                         expected="a sum of 1 (within 1 %); give 'hours' for raw counts")
    return Histogram(tuple(float(x) for x in edges), tuple(float(x) for x in w / total))


def _histogram_header(path: Path, line: int, header: str) -> tuple[tuple[str, ...], str]:
    """The speed columns (edges or centres) and the weight column a header names."""
    names = [c.strip() for c in header.split(",")]
    if "v_low_m_s" in names or "v_high_m_s" in names:
        speed_cols = _SPEED_COLUMNS["edges"]
    elif "v_m_s" in names:
        speed_cols = _SPEED_COLUMNS["centres"]
    else:
        raise InputError(path, f"no wind-speed column in header {names}", line=line,
                         expected=_HISTOGRAM_EXPECTED)
    weights = [c for c in _WEIGHT_COLUMNS if c in names]
    if len(weights) != 1:
        raise InputError(path, f"header {names} has {len(weights)} of 'hours'/'probability'",
                         line=line, expected=_HISTOGRAM_EXPECTED)
    for c in (*speed_cols, weights[0]):
        if c not in names:
            raise InputError(path, f"column {c!r} missing", line=line,
                             expected=_HISTOGRAM_EXPECTED)
    return speed_cols, weights[0]


def _histogram_values(path: Path, rows: list[tuple[int, str]],
                      wanted: tuple[str, ...]) -> tuple[dict[str, list[float]], list[int]]:
    """The ``wanted`` columns of the data rows (finite numbers >= 0) and their line numbers."""
    names = [c.strip() for c in rows[0][1].split(",")]
    index = {c: names.index(c) for c in wanted}
    values: dict[str, list[float]] = {c: [] for c in wanted}
    lines: list[int] = []
    for n, line in rows[1:]:
        cells = [c.strip() for c in line.split(",")]
        if len(cells) != len(names):
            raise InputError(path, f"{len(cells)} fields, the header has {len(names)}", line=n)
        for c in wanted:
            try:
                x = float(cells[index[c]])
            except ValueError:
                raise InputError(path, f"{cells[index[c]]!r} is not a number", line=n, column=c,
                                 expected="a finite number") from None
            if not math.isfinite(x) or x < 0:
                raise InputError(path, f"{cells[index[c]]!r} is not a finite number >= 0",
                                 line=n, column=c, expected="a finite number >= 0")
            values[c].append(x)
        lines.append(n)
    if not lines:
        raise InputError(path, "no data rows", expected=_HISTOGRAM_EXPECTED)
    return values, lines


def _edges_of_bins(path: Path, values: dict[str, list[float]], lines: list[int]) -> np.ndarray:
    """Bin edges from ``v_low_m_s, v_high_m_s``: sorted, adjacent, non-empty bins."""
    lo, hi = np.array(values["v_low_m_s"]), np.array(values["v_high_m_s"])
    for k in range(len(lo)):
        if hi[k] <= lo[k]:
            raise InputError(path, f"bin {lo[k]:g}-{hi[k]:g} m/s is empty", line=lines[k],
                             column="v_high_m_s", expected="v_high_m_s > v_low_m_s")
        if k and abs(lo[k] - hi[k - 1]) > 1e-9 * max(1.0, hi[k - 1]):
            raise InputError(path, f"bin starts at {lo[k]:g} m/s, the previous ended at "
                             f"{hi[k - 1]:g} m/s", line=lines[k], column="v_low_m_s",
                             expected="sorted, adjacent bins (no gaps, no overlaps)")
    return np.concatenate([lo[:1], hi])


def _edges_of_centres(path: Path, values: dict[str, list[float]],
                      lines: list[int]) -> np.ndarray:
    """Bin edges from ``v_m_s`` centres: the midpoints, the outer edges half a spacing out
    (clipped at 0)."""
    v = np.array(values["v_m_s"])
    for k in range(1, len(v)):
        if v[k] <= v[k - 1]:
            raise InputError(path, f"centre {v[k]:g} m/s is not above the previous "
                             f"{v[k - 1]:g} m/s", line=lines[k], column="v_m_s",
                             expected="strictly increasing bin centres")
    if len(v) < 2:
        raise InputError(path, "one bin centre cannot define a bin width", line=lines[0],
                         column="v_m_s", expected="at least two bins, or give bin edges")
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[max(0.0, v[0] - (mid[0] - v[0]))], mid,
                           [v[-1] + (v[-1] - mid[-1])]])
