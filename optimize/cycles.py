"""One optimal cycle: a scenario's collocation points (its rows of ``trajectories.parquet``,
docs/schemas.md §5) and the figures derived from them, each computed here once.

* :class:`Cycle`: a converged scenario's cycle, the one home of its figures (averages,
  energy over the cycle, metrics, the closed cycle) and its plot; :func:`sweep_cycles`
  makes them of a sweep's summary and trajectories;
* :func:`cycle_quadrature`: the collocation quadrature over the ``weight`` column (each
  point's share of the period, summing to 1 over a cycle): a cycle average, or its
  running sum (the energy over the cycle);
* :func:`cycle_metrics`: the figures of a cycle (average powers, peaks, RMS torque,
  ranges) the summary and the solve records carry;
* :func:`closed_cycle`: the points sorted by time and closed at ``t = 0`` by periodicity,
  as the figures draw them.

This module imports no solver: the later stages (``bench aep``, the report, the API)
use it through :mod:`optimize.door`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd


def cycle_quadrature(weight: Any, values: Any, *, cumulative: bool = False) -> Any:
    """The collocation quadrature over one cycle: ``sum_i weight_i * values_i``.

    Parameters
    ----------
    weight : (n,) array_like
        Each collocation point's quadrature weight as a share of the period (the
        trajectory's ``weight`` column; they sum to 1 over a cycle) [-].
    values : (n,) array_like
        The quantity at the points (a power [W], a squared torque [N^2 m^2], an
        indicator...).
    cumulative : bool
        Return the running sum up to and including each point instead of the total.

    Returns
    -------
    float or (n,) ndarray
        The cycle average of ``values`` (their unit); with ``cumulative``, the running
        sums, whose last value is that average. Times the period [s], a power's average
        is the net energy per cycle [J].
    """
    terms = np.asarray(weight, dtype=float) * np.asarray(values, dtype=float)
    return np.cumsum(terms) if cumulative else float(np.sum(terms))


#: each figure of :func:`cycle_metrics`: the columns it reads and how
CYCLE_FIGURES: dict[str, tuple[tuple[str, ...], Any]] = {
    "avg_p_elec_w": (("weight", "p_elec_w"), cycle_quadrature),
    "avg_p_mech_w": (("weight", "p_mech_w"), cycle_quadrature),
    "peak_speed_rpm": (("speed_rpm",), lambda n: np.max(np.abs(n))),
    "peak_torque_nm": (("torque_nm",), lambda t: np.max(np.abs(t))),
    "rms_torque_nm": (("weight", "torque_nm"), lambda w, t: np.sqrt(cycle_quadrature(w, t**2))),
    "peak_reel_acceleration_m_s2": (("ddl_m_s2",), lambda a: np.max(np.abs(a))),
    "p_elec_max_w": (("p_elec_w",), np.max),
    "p_elec_min_w": (("p_elec_w",), np.min),
    "tether_length_min_m": (("l_m",), np.min),
    "tether_length_max_m": (("l_m",), np.max),
    "altitude_min_m": (("altitude_m",), np.min),
    "altitude_max_m": (("altitude_m",), np.max),
}


def cycle_metrics(trajectory: Any) -> dict[str, float | None]:
    """The figures of one cycle from its trajectory (the one place they are computed).

    ``trajectory`` (a solve's trajectory, a scenario's rows of ``trajectories.parquet``,
    or a table with some of their columns): the cycle averages of the electrical and
    shaft power [W], the peak |speed| [rpm], |torque| [N m] and |reel acceleration|
    [m/s^2], the RMS torque [N m], the largest and smallest electrical power [W], the
    tether length's [m] and the altitude's [m] range (:data:`CYCLE_FIGURES`); None for a
    figure whose columns the trajectory has not. A part's own figures are the part's
    (:func:`optimize.solve.result.part_figures`).
    """
    out: dict[str, float | None] = {}
    for name, (columns, how) in CYCLE_FIGURES.items():
        have = all(c in trajectory for c in columns)
        out[name] = (float(how(*(np.asarray(trajectory[c], dtype=float) for c in columns)))
                     if have else None)
    return out


def closed_cycle(rows: pd.DataFrame) -> pd.DataFrame:
    """A cycle's collocation points sorted by time, closed at t = 0 by periodicity.

    The points sit at ``time_s`` in ``(0, T]``; the state at 0 equals the state at
    T, so the last point is repeated at ``time_s = 0`` with quadrature weight 0.
    """
    rows = rows.sort_values("time_s")
    first = rows.iloc[[-1]].copy()
    first["time_s"] = 0.0
    first["weight"] = 0.0
    return pd.concat([first, rows], ignore_index=True)


@dataclass(frozen=True, eq=False)
class Cycle:
    """One converged scenario's optimal cycle and the figures derived from it.

    Attributes
    ----------
    scenario, kind : str
        The scenario's name and kind (a key of :data:`optimize.kinds.KINDS`).
    points : pandas.DataFrame
        Its collocation points sorted by time: ``time_s`` in ``(0, T]`` (the last point at
        the period's end), ``weight`` and the other columns of ``trajectories.parquet``.
    """

    scenario: str
    kind: str
    points: pd.DataFrame

    @classmethod
    def of(cls, rows: pd.DataFrame) -> Cycle:
        """The cycle of one scenario's rows of ``trajectories.parquet``."""
        rows = rows.sort_values("time_s")
        return cls(str(rows["scenario"].iloc[0]), str(rows["kind"].iloc[0]), rows)

    @property
    def wind_speed_m_s(self) -> float:
        """Its wind speed at the reference height [m/s]."""
        return float(self.points["wind_speed_m_s"].iloc[0])

    @property
    def period_s(self) -> float:
        """Its period [s]: the time of the last point."""
        return float(self.points["time_s"].iloc[-1])

    def average(self, column: str) -> float:
        """The cycle average of a column (its unit) by :func:`cycle_quadrature`."""
        return cycle_quadrature(self.points["weight"], self.points[column])

    def metrics(self) -> dict[str, float | None]:
        """Its figures (:func:`cycle_metrics`)."""
        return cycle_metrics(self.points)

    def closed(self) -> pd.DataFrame:
        """Its points closed at ``t = 0`` (:func:`closed_cycle`), as figures draw them."""
        return closed_cycle(self.points)

    def energy_j(self, column: str) -> np.ndarray:
        """The energy [J] of a power column [W] from the cycle's start to each point of
        :meth:`closed` (0 at ``t = 0``; the last value is the net energy per cycle)."""
        closed = self.closed()
        return self.period_s * cycle_quadrature(closed["weight"], closed[column],
                                                cumulative=True)

    def plot(self, ax: Any = None, *, title: str | None = None) -> Any:
        """Shaft and grid power over the cycle (:func:`optimize.plots.plot_cycle`)."""
        from optimize.plots import plot_cycle

        return plot_cycle(self.closed(), ax, title=self.scenario if title is None else title,
                          kind=self.kind)


def sweep_cycles(summary: pd.DataFrame, trajectories: pd.DataFrame) -> dict[str, Cycle]:
    """The cycles of a sweep's converged scenarios that have points, by scenario name, in
    the summary's order (``summary.parquet``'s and ``trajectories.parquet``'s frames)."""
    groups = dict(tuple(trajectories.groupby("scenario", sort=False)))
    ok = summary[summary["success"].astype(bool)]
    return {str(name): Cycle.of(groups[name]) for name in ok["scenario"] if name in groups}
