"""The figures of the energy stage, as plotting functions: each takes an optional ``ax``
and returns it, so the report and a notebook draw the same figure with the same code.

============================ ==========================================================
:func:`plot_power_curves`    delivered power against wind speed per scenario kind, with
                             the 95 % band of the electrical power
:func:`plot_aep`             electrical and mechanical AEP per scenario kind, with bands
============================ ==========================================================

Each reads plain frames, the content of the stages' files (docs/schemas.md); without
``ax`` a new pyplot figure is made. The cycles' figures are :mod:`optimize.plots`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from energy.bands import Z95
from kernel.figure_text import new_axes, plain_label
from optimize.door import KINDS, SCENARIO_COLORS


def curve_frame(curves: pd.DataFrame | dict) -> pd.DataFrame:
    """The rows of ``power_curves.csv`` from that frame (returned as it is) or from a sweep's
    curves, scenario kind -> :class:`energy.curve.PowerCurve` (``Sweep.curves``: no band,
    ``p_elec_sigma_w`` NaN)."""
    if isinstance(curves, pd.DataFrame):
        return curves
    frames = [pd.DataFrame({"kind": kind, "wind_speed_m_s": c.wind_speed_m_s,
                            "p_elec_w": c.p_elec_w, "p_mech_w": c.p_mech_w,
                            "p_elec_sigma_w": np.nan})
              for kind, c in curves.items()]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(
        columns=["kind", "wind_speed_m_s", "p_elec_w", "p_mech_w", "p_elec_sigma_w"])


def plot_power_curves(curves: pd.DataFrame | dict, ax: Any = None) -> Any:
    """Delivered power against wind speed per scenario kind: electrical solid with its
    95 % band, mechanical dashed (positive = delivered).

    Parameters
    ----------
    curves : DataFrame or dict
        ``power_curves.csv`` of ``bench aep`` (or ``AepResult.assessment.curves``):
        ``kind``, ``wind_speed_m_s`` [m/s], ``p_elec_w``, ``p_mech_w`` [W] (our sign:
        negative = generated) and ``p_elec_sigma_w`` [W] (NaN: no band); or a sweep's
        curves (``Sweep.curves``, :func:`curve_frame`), drawn without a band.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
    """
    ax = new_axes(ax)
    curves = curve_frame(curves)
    for kind, rows in curves.groupby("kind", sort=False):
        rows = rows.sort_values("wind_speed_m_s")
        v = rows["wind_speed_m_s"].to_numpy(float)
        d = -rows["p_elec_w"].to_numpy(float)
        s = rows["p_elec_sigma_w"].to_numpy(float) if "p_elec_sigma_w" in rows else v * np.nan
        c = SCENARIO_COLORS.get(str(kind), "#444444")
        ax.plot(v, d, "o-", color=c, label=f"{plain_label(kind)} electrical")
        if np.all(np.isfinite(s)):
            ax.fill_between(v, d - Z95 * s, d + Z95 * s, color=c, alpha=0.25, lw=0)
        ax.plot(v, -rows["p_mech_w"].to_numpy(float), "--", color=c, lw=1, alpha=0.8,
                label=f"{plain_label(kind)} mechanical (shaft)")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("wind speed at the reference height [m/s]")
    ax.set_ylabel("average power delivered [W]")
    ax.set_title("Power curves (solid: electrical with 95 % band; dashed: mechanical)",
                 fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    return ax


def plot_aep(table: pd.DataFrame, ax: Any = None) -> Any:
    """Electrical and mechanical AEP per scenario kind [MWh/yr], the electrical with its
    95 % band.

    Parameters
    ----------
    table : DataFrame
        One row per kind: ``kind``, ``aep_elec_mwh``, ``aep_mech_mwh`` and, when known,
        ``ci95_aep_elec_low_mwh``, ``ci95_aep_elec_high_mwh`` (the ``kinds`` of
        ``aep.json``, or ``AepResult.table()``).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
    """
    ax = new_axes(ax, (6.0, 3.6))
    kinds = [str(k) for k in table["kind"]]
    x = np.arange(len(kinds))
    elec = table["aep_elec_mwh"].to_numpy(float)
    lo = pd.to_numeric(table.get("ci95_aep_elec_low_mwh", pd.Series(np.nan, table.index)),
                       errors="coerce").to_numpy(float)
    hi = pd.to_numeric(table.get("ci95_aep_elec_high_mwh", pd.Series(np.nan, table.index)),
                       errors="coerce").to_numpy(float)
    err = np.vstack([elec - lo, hi - elec])
    colors = [SCENARIO_COLORS.get(k, "#444444") for k in kinds]
    ax.bar(x - 0.2, elec, 0.4, color=colors, label="electrical (95 % band)",
           yerr=np.where(np.isfinite(err), err, 0.0), capsize=3)
    ax.bar(x + 0.2, table["aep_mech_mwh"].to_numpy(float), 0.4, color=colors, alpha=0.35,
           hatch="//", label="mechanical (shaft)")
    ax.set_xticks(x, [f"{k}\n{_short_label(k)}" for k in kinds], fontsize=7)
    ax.set_ylabel("AEP [MWh/yr]")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, axis="y")
    return ax


def _short_label(kind: str) -> str:
    k = KINDS.get(kind)
    if k is None:
        return ""
    return f"{k.objective[:4]}. optimized, {'with' if k.drive_limits else 'no'} limits"
