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
from matplotlib.patches import Rectangle

from kernel.names import WINDING_TEMPERATURE
from optimize.door import (
    KINDS,
    LABELS,
    MARKER_STEP_S,
    SCENARIO_COLORS,
    Cycle,
    equal_time_samples,
    plot_cycle,
    plot_efficiency_map,
)
from reports.svg import new_figure, to_svg


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


def torque_speed_figure(limited: dict[str, pd.DataFrame], free: dict[str, pd.DataFrame],
                        wind_speed_m_s: float, drawn_map: dict | None,
                        envelope: tuple[np.ndarray, np.ndarray] | None = None,
                        paper: bool = True) -> Markup:
    """Cycles in the torque-speed plane (paper Fig. 9).

    Panel (a): the cycles with the drive limits over the efficiency map
    (:func:`optimize.plots.plot_efficiency_map`, within the map's axes), where the
    electrical optimum's move to efficient regions shows. Panel (b): the cycles without
    limits (the paper's Fig. 9), which leave the measured map, with the map's extent
    outlined. Markers are equally spaced in time (:data:`optimize.plots.MARKER_STEP_S`).

    Parameters
    ----------
    limited, free : dict
        kind key -> closed cycle with ``time_s`` [s], ``speed_rpm`` [rpm], ``torque_nm``
        [N m]; either may be empty (its panel is left out).
    wind_speed_m_s : float
        The wind speed of the cycles [m/s], for the titles.
    drawn_map : dict or None
        ``map_frame`` (``efficiency_map.parquet``) and ``domain`` of the efficiency map;
        None: panel (a) draws the cycles without the map.
    envelope : (ndarray, ndarray), optional
        The drive's torque-speed envelope, drawn over panel (a)'s map.
    paper : bool
        The sweep flew the paper's system: panel (b) is named as the paper's figure.
    """
    panels = [p for p in (limited, free) if p]
    fig = new_figure(8.0, 3.8 * len(panels))
    axes = iter(fig.subplots(len(panels), 1, squeeze=False)[:, 0])
    step = f"a marker every {MARKER_STEP_S * 1e3:.0f} ms"
    if limited:
        ax = next(axes)
        if drawn_map is not None:
            plot_efficiency_map(drawn_map["map_frame"], ax, domain=drawn_map["domain"],
                                      cycles=limited, envelope=envelope)
            ax.patch.set_gid("fig9-map-axes")  # the SVG id of the map's axes
        else:
            _cycles_panel(ax, limited, None)
        ax.set_title(f"(a) with the drive limits, {wind_speed_m_s:g} m/s"
                     + (", over the measured efficiency map" if drawn_map is not None else "")
                     + f"; {step}", fontsize=9)
    if free:
        ax = next(axes)
        _cycles_panel(ax, free, drawn_map["map_frame"] if drawn_map is not None else None)
        ax.set_title(f"({'b' if limited else 'a'}) without drive limits"
                     + (" (the paper's Fig. 9)" if paper else "")
                     + f", {wind_speed_m_s:g} m/s; {step}", fontsize=9)
    return to_svg(fig, "torque-speed")


def _cycles_panel(ax, cycles: dict[str, pd.DataFrame], map_frame: pd.DataFrame | None) -> None:
    """Cycles in the torque-speed plane on axes that hold them all; the extent of the
    efficiency map (when given) outlined, dashed."""
    for key, cycle in cycles.items():
        smp = equal_time_samples(cycle, ("speed_rpm", "torque_nm"))
        ax.plot(smp["speed_rpm"], smp["torque_nm"], marker=".", ms=3, lw=0.5,
                color=SCENARIO_COLORS[key], label=LABELS[key])
    if map_frame is not None and len(map_frame):
        s, t = map_frame["speed_rpm"].to_numpy(float), map_frame["torque_nm"].to_numpy(float)
        ax.add_patch(Rectangle((s.min(), t.min()), np.ptp(s), np.ptp(t), fill=False, ls="--",
                               lw=0.8, color="0.4", label="extent of the measured map"))
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel("drum speed [rpm] (reel-out / generating < 0)")
    ax.set_ylabel("drum torque [N m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")


def power_flow_figure(cycles: dict[str, pd.DataFrame], wind_speed_m_s: float) -> Markup:
    """Mechanical and electrical power over one cycle, one panel per cycle (paper Fig. 10;
    each panel :func:`optimize.plots.plot_cycle`).

    Parameters
    ----------
    cycles : dict
        kind key -> trajectory frame with ``time_s`` [s], ``p_mech_w`` [W]
        and ``p_elec_w`` [W] (positive = drawn from the grid / delivered to the shaft).
    wind_speed_m_s : float
        Wind speed [m/s], for the titles.
    """
    fig = new_figure(9.0, 3.6)
    axes = np.atleast_1d(fig.subplots(1, len(cycles), sharey=True))
    for k, (ax, (key, traj)) in enumerate(zip(axes, cycles.items(), strict=True)):
        plot_cycle(traj, ax, title=f"{LABELS[key]}, {wind_speed_m_s:g} m/s", kind=key)
        if k:
            ax.set_ylabel("")
    return to_svg(fig, "power-flows")


def cycle_figure(cycle: Cycle, label: str, winding_limit_c: float | None = None) -> Markup:
    """Tether length, power and energy over one cycle (paper Fig. 3), and the winding
    temperature when the cycle carries it.

    Parameters
    ----------
    cycle : optimize.cycles.Cycle
        The cycle: its points have ``l_m`` [m], ``p_elec_w``, ``p_mech_w`` [W] and, when the
        OCP carried it, ``theta_winding_c`` [degC]; drawn closed, from t = 0.
    label : str
        What the cycle is (our constant text, e.g. "elec. optimized, constrained, 5.5 m/s").
    winding_limit_c : float, optional
        The drive's winding limit [degC], drawn with the temperature.
    """
    traj = cycle.closed()
    t = traj["time_s"].to_numpy(float)
    hot = WINDING_TEMPERATURE in traj
    fig = new_figure(7.0, 7.6 if hot else 6.0)
    ax_l, ax_p, ax_e, *ax_t = fig.subplots(4 if hot else 3, 1, sharex=True)
    ax_l.plot(t, traj["l_m"], color="k")
    ax_l.set_ylabel("tether length [m]")
    ax_l.set_title(label, fontsize=10)
    plot_cycle(traj, ax_p, kind="elec-lim")
    ax_p.set_xlabel("")
    for col, color, name in (("p_elec_w", "tab:blue", "electrical"),
                             ("p_mech_w", "0.3", "mechanical")):
        e = cycle.energy_j(col)
        ax_e.plot(t, e, color=color, label=f"E {name}: net {e[-1]:+.0f} J")
    ax_e.set_ylabel("energy [J]\n(+ = consumed)")
    ax_e.set_xlabel("" if hot else "time [s]")
    for ax in (ax_l, ax_e):
        ax.grid(alpha=0.3)
    ax_e.axhline(0.0, color="k", lw=0.6)
    ax_e.legend(fontsize=7, loc="best")
    if hot:
        _winding_panel(ax_t[0], t, traj[WINDING_TEMPERATURE].to_numpy(float), winding_limit_c)
    return to_svg(fig, "cycle")


def _winding_panel(ax, t: np.ndarray, theta_c: np.ndarray, limit_c: float | None) -> None:
    """The winding temperature over the cycle (its cyclic steady state), with the limit."""
    ax.plot(t, theta_c, color="tab:red", gid="winding-temperature",
            label=f"winding: peak {theta_c.max():.2f} degC")
    if limit_c is not None:
        ax.axhline(limit_c, color="k", ls="--", lw=0.8,
                   label=f"limit {limit_c:g} degC (margin {limit_c - theta_c.max():.2f} K)")
    ax.set_ylabel("winding [degC]")
    ax.set_xlabel("time [s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
