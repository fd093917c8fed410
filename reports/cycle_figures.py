"""Figures of the optimized cycles: Fig. 8 (power vs wind), Fig. 9, Fig. 10, Fig. 3 analogues.

Pure functions of frames read from ``optimize_out``; each returns inline SVG.
Sign convention as everywhere (positive = drawn from the grid / delivered to
the shaft) except in :func:`power_vs_wind_figure`, which, like the paper's
Fig. 8, plots *generated* power (positive = good) and says so on its axis.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from markupsafe import Markup

from fitting.figures import draw_efficiency
from optimize.kinds import KINDS, LABELS
from reports.svg import SCENARIO_COLORS, new_figure, to_svg


def power_vs_wind_figure(summary: pd.DataFrame, power_column: str, name: str,
                         title: str) -> Markup:
    """Average generated power against wind speed for the four scenario kinds (Fig. 8a/8b).

    Parameters
    ----------
    summary : DataFrame
        One row per scenario with ``kind`` (a key of :data:`optimize.kinds.KINDS`),
        ``wind_speed_m_s`` [m/s], ``ok`` (bool) and ``power_column`` [W] (our sign:
        negative = generated). Failed scenarios (``ok`` False) are not plotted.
    power_column : str
        ``avg_p_elec_w`` or ``avg_p_mech_w``.
    name, title : str
        Figure name (unique) and title.
    """
    fig = new_figure(6.4, 4.0)
    ax = fig.add_subplot()
    for key, label in LABELS.items():
        rows = summary[summary["kind"] == key]
        if rows.empty:
            continue
        rows = rows.sort_values("wind_speed_m_s")
        good = rows[rows["ok"]]
        n_failed = int((~rows["ok"]).sum())
        text = label + (f" ({n_failed} failed, not shown)" if n_failed else "")
        ax.plot(good["wind_speed_m_s"], -good[power_column], marker="o", ms=4,
                color=SCENARIO_COLORS[key], ls="-" if KINDS[key].drive_limits else "--", label=text)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("wind speed at 100 m [m/s]")
    ax.set_ylabel("average GENERATED power [W]\n(positive = delivered, as paper Fig. 8)")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    return to_svg(fig, name)


#: Time between the markers of Fig. 9 [s]: equal spacing, so marker density shows dwell time.
MARKER_STEP_S = 0.04


def equal_time_samples(traj: pd.DataFrame, columns: tuple[str, ...],
                       step_s: float = MARKER_STEP_S) -> dict[str, np.ndarray]:
    """Columns of a closed cycle resampled at equal time steps (linear interpolation).

    Parameters
    ----------
    traj : DataFrame
        Closed cycle (first row at t = 0) with ``time_s`` [s] and ``columns``.
    columns : tuple of str
        Columns to resample.
    step_s : float
        Time step [s].
    """
    t = traj["time_s"].to_numpy(float)
    grid = np.arange(0.0, t[-1], step_s)
    return {c: np.interp(grid, t, traj[c].to_numpy(float)) for c in columns}


def torque_speed_figure(cycles: dict[str, pd.DataFrame], wind_m_s: float,
                        grid: tuple[np.ndarray, np.ndarray, np.ndarray] | None) -> Markup:
    """Torque-speed trajectories of the cycles over the efficiency map (paper Fig. 9).

    Panel (a) shows all cycles over the map, then one detail panel per cycle.
    Markers are equally spaced in time (:data:`MARKER_STEP_S`), so where they
    crowd the cycle dwells, as in the paper.

    Parameters
    ----------
    cycles : dict
        kind key -> closed cycle with ``time_s`` [s], ``speed_rpm``
        [rpm] and ``torque_nm`` [N m].
    wind_m_s : float
        The wind speed of the cycles [m/s], for the title.
    grid : tuple or None
        (speed_rpm, torque_nm, eta) of the efficiency map, drawn beneath if given.
    """
    fig = new_figure(9.0, 7.0)
    gs = fig.add_gridspec(2, max(1, len(cycles)))
    ax_all = fig.add_subplot(gs[0, :])
    details = [fig.add_subplot(gs[1, k]) for k in range(len(cycles))]
    samples = {key: equal_time_samples(traj, ("speed_rpm", "torque_nm"))
               for key, traj in cycles.items()}
    for k, ax in enumerate([ax_all, *details]):
        if grid is not None:
            draw_efficiency(ax, *grid, colorbar=k == 0)
        keys = list(samples) if k == 0 else [list(samples)[k - 1]]
        for key in keys:
            smp = samples[key]
            ax.plot(smp["speed_rpm"], smp["torque_nm"], marker=".", ms=3, lw=0.5,
                    color=SCENARIO_COLORS[key], label=LABELS[key])
        if k > 0:
            smp = samples[keys[0]]
            pad_s = 0.05 * np.ptp(smp["speed_rpm"]) + 10.0
            pad_t = 0.05 * np.ptp(smp["torque_nm"]) + 1.0
            ax.set_xlim(smp["speed_rpm"].min() - pad_s, smp["speed_rpm"].max() + pad_s)
            ax.set_ylim(smp["torque_nm"].min() - pad_t, smp["torque_nm"].max() + pad_t)
            ax.set_title(f"({chr(ord('a') + k)}) {LABELS[keys[0]]}", fontsize=9)
        ax.axvline(0.0, color="k", lw=0.6)
    ax_all.set_xlabel("drum speed [rpm] (reel-out / generating < 0)")
    ax_all.set_title(f"(a) torque-speed trajectories at {wind_m_s:g} m/s, a marker every "
                     f"{MARKER_STEP_S * 1e3:.0f} ms", fontsize=10)
    ax_all.legend(fontsize=7, loc="upper right")
    return to_svg(fig, "torque-speed")


def power_flow_figure(cycles: dict[str, pd.DataFrame], wind_m_s: float) -> Markup:
    """Mechanical and electrical power over one cycle, one panel per cycle (paper Fig. 10).

    Parameters
    ----------
    cycles : dict
        kind key -> trajectory frame with ``time_s`` [s], ``p_mech_w`` [W]
        and ``p_elec_w`` [W] (positive = drawn from the grid / delivered to the shaft).
    wind_m_s : float
        Wind speed [m/s], for the titles.
    """
    fig = new_figure(9.0, 3.6)
    axes = np.atleast_1d(fig.subplots(1, len(cycles), sharey=True))
    for ax, (key, traj) in zip(axes, cycles.items(), strict=True):
        t = traj["time_s"].to_numpy(float)
        ax.plot(t, traj["p_mech_w"] / 1e3, color="0.3", label="P_mech (shaft)")
        ax.plot(t, traj["p_elec_w"] / 1e3, color=SCENARIO_COLORS[key], label="P_elec (grid)")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_title(f"{LABELS[key]}, {wind_m_s:g} m/s", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("power [kW] (+ = drawn from grid)")
    return to_svg(fig, "power-flows")


def cycle_energy(weight: np.ndarray, power_w: np.ndarray, period_s: float) -> np.ndarray:
    """Cumulative energy [J] over a cycle by the collocation quadrature.

    Parameters
    ----------
    weight : (n,) array
        Quadrature weight of each collocation point as a fraction of the period
        (the trajectory's ``weight`` column; they sum to 1 over a cycle) [-].
    power_w : (n,) array
        Power at the points [W].
    period_s : float
        Cycle period [s].

    Returns
    -------
    (n,) array
        Energy [J] up to and including each point; the last value is the net
        energy of the cycle, ``mean power * period``.
    """
    return period_s * np.cumsum(np.asarray(weight, float) * np.asarray(power_w, float))


def cycle_figure(traj: pd.DataFrame, period_s: float, label: str) -> Markup:
    """Tether length, power and energy over one cycle (paper Fig. 3).

    Parameters
    ----------
    traj : DataFrame
        Closed cycle (first row at t = 0) with ``time_s`` [s], ``weight`` [-],
        ``l_m`` [m], ``p_elec_w``, ``p_mech_w`` [W].
    period_s : float
        Cycle period [s].
    label : str
        What the cycle is (our constant text, e.g. "elec. optimized, constrained, 5.5 m/s").
    """
    t = traj["time_s"].to_numpy(float)
    fig = new_figure(7.0, 6.0)
    ax_l, ax_p, ax_e = fig.subplots(3, 1, sharex=True)
    ax_l.plot(t, traj["l_m"], color="k")
    ax_l.set_ylabel("tether length [m]")
    ax_l.set_title(label, fontsize=10)
    for col, color, name in (("p_elec_w", "tab:blue", "electrical"),
                             ("p_mech_w", "0.4", "mechanical")):
        p = traj[col].to_numpy(float)
        ax_p.plot(t, p / 1e3, color=color, label=f"P {name}")
        e = cycle_energy(traj["weight"].to_numpy(float), p, period_s)
        ax_e.plot(t, e, color=color, label=f"E {name}: net {e[-1]:+.0f} J")
    ax_p.set_ylabel("power [kW]\n(+ = consumed)")
    ax_e.set_ylabel("energy [J]\n(+ = consumed)")
    ax_e.set_xlabel("time [s]")
    for ax in (ax_l, ax_p, ax_e):
        ax.grid(alpha=0.3)
    for ax in (ax_p, ax_e):
        ax.axhline(0.0, color="k", lw=0.6)
        ax.legend(fontsize=7, loc="best")
    return to_svg(fig, "cycle")
