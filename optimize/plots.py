"""The figures of optimal cycles, as plotting functions: each takes an optional ``ax``
and returns it, so the report and a notebook draw the same figure with the same code.

============================ ==========================================================
:func:`plot_cycle`           shaft and grid power over one cycle (paper Figs. 3, 10)
:func:`plot_efficiency_map`  the measured efficiency map (paper Fig. 5), optionally with
                             cycles in the torque-speed plane over it (paper Fig. 9)
============================ ==========================================================

Each reads plain frames, the content of the stages' files (docs/schemas.md); without
``ax`` a new pyplot figure is made. Nothing here selects a matplotlib backend beyond what
:mod:`fitting.figures` does. The power curves and the AEP are :mod:`energy.plots`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from fitting import figures
from kernel.figure_text import fit_title, new_axes
from optimize.kinds import LABELS

#: Colours of the four scenario kinds, shared by every figure of the cycles.
SCENARIO_COLORS = {
    "elec-lim": "#1f77b4",
    "elec-free": "#17becf",
    "mech-lim": "#d62728",
    "mech-free": "#ff7f0e",
}
#: Time between the markers of a cycle in the torque-speed plane [s]: equal spacing, so
#: marker density shows dwell time, as in the paper's Fig. 9.
MARKER_STEP_S = 0.04


def equal_time_samples(cycle: pd.DataFrame, columns: tuple[str, ...],
                       step_s: float = MARKER_STEP_S) -> dict[str, np.ndarray]:
    """Columns of a closed cycle resampled at equal time steps (linear interpolation).

    Parameters
    ----------
    cycle : DataFrame
        Closed cycle (first row at t = 0) with ``time_s`` [s] and ``columns``.
    columns : tuple of str
        Columns to resample.
    step_s : float
        Time step [s].
    """
    t = cycle["time_s"].to_numpy(float)
    grid = np.arange(0.0, t[-1], step_s)
    return {c: np.interp(grid, t, cycle[c].to_numpy(float)) for c in columns}


def plot_efficiency_map(map_frame: pd.DataFrame, ax: Any = None, *, domain: dict | None = None,
                        masking: dict | None = None,
                        cycles: dict[str, pd.DataFrame] | None = None,
                        envelope: tuple[np.ndarray, np.ndarray] | None = None) -> Any:
    """The measured efficiency map (paper Fig. 5), with cycles over it (paper Fig. 9).

    Parameters
    ----------
    map_frame : DataFrame
        ``efficiency_map.parquet`` of ``bench fit``: ``speed_rpm`` [rpm], ``torque_nm``
        [N m], ``eta`` [-] and, when present, ``status``.
    ax : matplotlib Axes, optional
        Where to draw; default a new figure.
    domain : dict, optional
        ``quadrant -> polygon`` of the power model's validity domain, outlined.
    masking : dict, optional
        The fit's masking rules, named in the legend.
    cycles : dict, optional
        Scenario kind (a key of :data:`optimize.kinds.KINDS`) -> closed cycle with
        ``time_s`` [s], ``speed_rpm`` [rpm], ``torque_nm`` [N m]; drawn with a marker
        every :data:`MARKER_STEP_S` (SVG id ``cycle-<kind>``). The axes keep the map's
        extent: the part of a cycle beyond the map is cut off, and the legend says which
        cycles leave it.
    envelope : (ndarray, ndarray), optional
        The drive's torque-speed envelope the optimizer flew with: speeds [rpm] and
        largest torques [N m] (:func:`optimize.model.envelope.envelope_curve`), drawn
        dashed (SVG id ``drive-envelope``).

    Returns
    -------
    matplotlib Axes
    """
    ax = new_axes(ax, (7.0, 4.0))
    figures.draw_efficiency_map(ax, map_frame, domain, masking)
    fit_title(ax)  # the title within its own axes, never over a neighbouring panel
    if envelope is not None:
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        ax.plot(*envelope, ls="--", lw=1.0, color="k", label="drive torque-speed envelope",
                gid="drive-envelope")
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.legend(loc="upper left", fontsize=7)
    if cycles:
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        for kind, cycle in cycles.items():
            smp = equal_time_samples(cycle, ("speed_rpm", "torque_nm"))
            s, t = smp["speed_rpm"], smp["torque_nm"]
            inside = float(np.mean((s >= x0) & (s <= x1) & (t >= y0) & (t <= y1)))
            ax.plot(s, t, marker=".", ms=3, lw=0.5, color=SCENARIO_COLORS.get(kind, "k"),
                    label=LABELS.get(kind, kind) + ("" if inside == 1.0 else
                                                    f" ({100 * inside:.0f} % on the map)"),
                    gid=f"cycle-{kind}")  # the SVG element's id
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.legend(loc="upper left", fontsize=7)
    return ax


def plot_cycle(cycle: pd.DataFrame, ax: Any = None, *, title: str | None = None,
               kind: str | None = None) -> Any:
    """Shaft and grid power over one cycle [kW] (positive = drawn from the grid /
    delivered to the shaft), the panels of paper Figs. 3 and 10.

    Parameters
    ----------
    cycle : DataFrame
        One cycle's collocation points: ``time_s`` [s], ``p_mech_w``, ``p_elec_w`` [W]
        (a ``trajectories.parquet`` scenario's rows).
    ax : matplotlib Axes, optional
    title : str, optional
    kind : str, optional
        The scenario kind, for the colour of the electrical power.

    Returns
    -------
    matplotlib Axes
    """
    ax = new_axes(ax, (5.0, 3.4))
    cycle = cycle.sort_values("time_s")
    t = cycle["time_s"].to_numpy(float)
    ax.plot(t, cycle["p_mech_w"] / 1e3, color="0.3", label="P_mech (shaft)")
    ax.plot(t, cycle["p_elec_w"] / 1e3, color=SCENARIO_COLORS.get(kind, "tab:blue"),
            label="P_elec (grid)")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("power [kW]\n(+ = drawn from grid)")
    if title:
        ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return ax
