"""Figures of the drive as inline SVG: measured points, and the fit's efficiency map
(Fig. 5), power map (Fig. 6) and residuals drawn by :mod:`fitting.figures`.

Pure functions of the data frames read from the store and the fit outputs; each
returns inline SVG markup (:func:`reports.svg.to_svg`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from markupsafe import Markup

from fitting import figures
from fitting.power_model import PowerModel
from kernel.figure_text import plain_label
from optimize.door import plot_efficiency_map
from reports.svg import new_figure, to_svg


def operating_points_figure(points: pd.DataFrame) -> Markup:
    """Speed-torque scatter of the accepted operating points, coloured by quadrant.

    Parameters
    ----------
    points : DataFrame
        Store points (``speed_rpm`` [rpm], ``torque_nm`` [N m], ``quadrant``).
    """
    fig = new_figure(7.0, 3.8)
    ax = fig.add_subplot()
    for quadrant, group in points.groupby("quadrant", sort=True):
        ax.scatter(
            group["speed_rpm"], group["torque_nm"], s=6, alpha=0.7,
            color=figures.QUADRANT_COLORS.get(str(quadrant), "grey"),
            label=f"{plain_label(quadrant)} ({len(group)})",
            rasterized=len(points) > figures.RASTER_ABOVE_POINTS,
        )
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel("drum speed [rpm] (reel-out / generating < 0)")
    ax.set_ylabel("drum torque [N m]")
    ax.set_title("Accepted operating points")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return to_svg(fig, "operating-points")


def efficiency_map_figure(map_frame: pd.DataFrame, domain: dict | None = None,
                          name: str = "efficiency-map") -> Markup:
    """The measured efficiency map (paper Fig. 5; :func:`optimize.plots.plot_efficiency_map`).

    Parameters
    ----------
    map_frame : DataFrame
        ``efficiency_map.parquet`` of ``bench fit``.
    domain : dict, optional
        The model's validity domain, outlined.
    name : str
        Figure name (unique in the report).
    """
    fig = new_figure(7.0, 4.0)
    plot_efficiency_map(map_frame, fig.add_subplot(), domain=domain)
    return to_svg(fig, name)


def power_map_figure(model: PowerModel, points: pd.DataFrame) -> Markup:
    """Fit against measured power map (paper Fig. 6; :func:`fitting.figures.draw_power_map`)."""
    fig = new_figure(7.0, 4.4)
    figures.draw_power_map(fig.add_subplot(), model, points)
    return to_svg(fig, "power-map")


def residual_figure(points: pd.DataFrame, residual_w: np.ndarray, nominal_power_w: float) -> Markup:
    """Residuals against speed, torque, and their histogram
    (:func:`fitting.figures.draw_residuals`)."""
    fig = new_figure(9.0, 3.2)
    figures.draw_residuals(fig.subplots(1, 3), points, residual_w, nominal_power_w)
    return to_svg(fig, "residuals")
