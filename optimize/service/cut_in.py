"""The cut-in wind speed of a kind: bisection for zero average electrical power."""

from __future__ import annotations

import math
from typing import Any

from optimize.problem.scenario import Scenario
from optimize.service.outcome import CutIn


def max_probes(wind_speeds_m_s: tuple[float, ...], tol_m_s: float) -> int:
    """The most probes one kind's search (:func:`find_cut_in`) solves on this grid: the
    bisection of its widest step [m/s] down to ``tol_m_s``."""
    widest = max((b - a for a, b in zip(wind_speeds_m_s, wind_speeds_m_s[1:], strict=False)),
                 default=0.0)
    return math.ceil(math.log2(widest / tol_m_s)) if widest > tol_m_s else 0


def find_cut_in(solves: Any, kind: str, grid: dict[float, float],
                tol_m_s: float = 0.05) -> CutIn:
    """Bisection on the wind speed for zero average electrical power.

    Parameters
    ----------
    solves : optimize.service.solves.Solves
        Has solved the grid speeds (their solutions warm-start the probes); each probe
        is one of its solves (role ``"cut-in"``, no cold start).
    kind : str
    grid : dict
        Converged grid points of ``kind``: wind [m/s] -> average electrical power [W].
    tol_m_s : float
        Final bracket width [m/s].

    Notes
    -----
    The bracket is the lowest pair of neighbouring converged grid speeds where
    the drive consumes (P_elec > 0) at the lower one and generates (P_elec <= 0)
    at the upper one. Each probe is warm-started from the nearer bracket end
    (the other end if that fails). The estimate is the linear interpolation of
    the crossing inside the final bracket.
    """
    nan = float("nan")
    wind_speeds_m_s = sorted(grid)
    if len(wind_speeds_m_s) < 2:
        return CutIn(kind, nan, nan, nan, "too few converged grid speeds")
    if all(grid[w] <= 0 for w in wind_speeds_m_s):
        return CutIn(kind, nan, nan, wind_speeds_m_s[0], "generates at every converged grid speed")
    pair = next(((a, b) for a, b in zip(wind_speeds_m_s, wind_speeds_m_s[1:], strict=False)
                 if grid[a] > 0 >= grid[b]), None)
    if pair is None:
        return CutIn(kind, nan, wind_speeds_m_s[-1], nan, "never generates on the grid")
    (lo, hi), probes = pair, []
    p_lo, p_hi = grid[lo], grid[hi]
    status = "found"
    while hi - lo > tol_m_s:
        mid = 0.5 * (lo + hi)
        ends = [lo, hi] if mid - lo < hi - mid else [hi, lo]
        probe = Scenario.of_kind(kind, mid)
        rec = solves.solve(probe, "cut-in", sources=[probe.at(w) for w in ends], cold=False)
        p_mid = rec["avg_p_elec_w"] if rec["avg_p_elec_w"] is not None else math.nan
        probes.append((mid, p_mid, rec["success"], rec["status"]))
        if not rec["success"]:
            status = f"probe failed at {mid:g} m/s"
            break
        if p_mid > 0:
            lo, p_lo = mid, p_mid
        else:
            hi, p_hi = mid, p_mid
    cut_in = lo + (hi - lo) * p_lo / (p_lo - p_hi) if status == "found" else nan
    return CutIn(kind, cut_in, lo, hi, status, tuple(probes))
