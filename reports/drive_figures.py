"""Figures of the drive: measured points, efficiency map (Fig. 5), power map (Fig. 6), residuals.

Pure functions of the data frames read from the store and the fit outputs; each
returns inline SVG markup (:func:`reports.svg.to_svg`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from markupsafe import Markup
from matplotlib.colors import ListedColormap
from matplotlib.path import Path as MplPath
from matplotlib.ticker import MaxNLocator
from matplotlib.tri import Triangulation

from fitting.model_file import PowerModel
from reports.svg import new_figure, plain_label, to_svg

QUADRANT_COLORS = {"motor": "#1f77b4", "generator": "#2ca02c"}

#: Above this many points, scatter layers are embedded as a bitmap inside the SVG, so
#: the report stays small (< 10 MB) for long ``bench synth --scale`` campaigns.
RASTER_ABOVE_POINTS = 2000

#: Efficiency levels outlined on the map [-].
EFFICIENCY_CONTOURS = (0.7, 0.8, 0.9)

#: Contour spacing of the power map [W] (paper Fig. 6: a line every 500 W).
POWER_CONTOUR_STEP_W = 500.0


def efficiency_colormap() -> ListedColormap:
    """Viridis with efficiency 0 (masked cells, paper: white) drawn white."""
    import matplotlib

    base = matplotlib.colormaps["viridis"].resampled(256)
    colors = base(np.linspace(0, 1, 256))
    colors[0] = (1.0, 1.0, 1.0, 1.0)
    return ListedColormap(colors, name="eta_white_zero")


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
            color=QUADRANT_COLORS.get(str(quadrant), "grey"),
            label=f"{plain_label(quadrant)} ({len(group)})",
            rasterized=len(points) > RASTER_ABOVE_POINTS,
        )
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel("drum speed [rpm] (reel-out / generating < 0)")
    ax.set_ylabel("drum torque [N m]")
    ax.set_title("Accepted operating points")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return to_svg(fig, "operating-points")


def efficiency_map_figure(
    speed_rpm: np.ndarray, torque_nm: np.ndarray, eta: np.ndarray, name: str = "efficiency-map"
) -> Markup:
    """Gridded efficiency map over both quadrants (paper Fig. 5).

    Parameters
    ----------
    speed_rpm : (n,) array
        Grid speeds [rpm], increasing.
    torque_nm : (m,) array
        Grid torques [N m], increasing.
    eta : (m, n) array
        Efficiency [-] per cell; 0 = masked (drawn white), NaN = outside the
        measured hull (not drawn).
    name : str
        Figure name (unique in the report).
    """
    fig = new_figure(7.0, 4.0)
    ax = fig.add_subplot()
    draw_efficiency(ax, speed_rpm, torque_nm, eta)
    if np.isfinite(eta).sum() >= 4 and len(speed_rpm) > 1 and len(torque_nm) > 1:
        cs = ax.contour(speed_rpm, torque_nm, np.ma.masked_invalid(eta),
                        levels=EFFICIENCY_CONTOURS, colors="k", linewidths=0.5)
        ax.clabel(cs, fontsize=7, fmt="%.2f")
    ax.set_title("Measured efficiency map (masked cells white), contours "
                 + ", ".join(f"{v:g}" for v in EFFICIENCY_CONTOURS), fontsize=9)
    return to_svg(fig, name)


def draw_efficiency(ax, speed_rpm, torque_nm, eta, colorbar: bool = True):
    """Draw the efficiency grid on ``ax`` (0 white, NaN not drawn); returns the mesh."""
    mesh = ax.pcolormesh(
        speed_rpm, torque_nm, np.ma.masked_invalid(eta), cmap=efficiency_colormap(),
        vmin=0.0, vmax=1.0, shading="nearest", rasterized=True,
    )
    if colorbar:
        ax.figure.colorbar(mesh, ax=ax, label="efficiency [-] (eqs. 1, 2)")
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel("drum speed [rpm] (generator < 0 < motor)")
    ax.set_ylabel("drum torque [N m]")
    return mesh


def power_map_figure(model: PowerModel, points: pd.DataFrame) -> Markup:
    """Fit against measured power map (paper Fig. 6): 500 W contours, zero line thicker.

    Solid black: the model, inside its validity domain (the measured hull per
    quadrant, when the model file has one); dashed red: contours of the measured
    points (triangulated per quadrant, so no contour crosses the unmeasured gap).

    Parameters
    ----------
    model : PowerModel
        The fitted drive model.
    points : DataFrame
        Store points (``speed_rpm``, ``torque_nm``, ``p_elec_w``, ``quadrant``).
    """
    fig = new_figure(7.0, 4.4)
    ax = fig.add_subplot()
    s_lo, s_hi = float(points["speed_rpm"].min()), float(points["speed_rpm"].max())
    t_lo, t_hi = 0.0, float(points["torque_nm"].max())
    sg, tg = np.meshgrid(np.linspace(s_lo, s_hi, 241), np.linspace(t_lo, t_hi, 121))
    pg = np.where(_in_domain(model, sg, tg), model.p_elec_w(sg, tg), np.nan)
    all_p = np.concatenate([pg[np.isfinite(pg)], points["p_elec_w"].to_numpy(float)])
    levels = _levels(all_p)
    ax.scatter(points["speed_rpm"], points["torque_nm"], s=3, color="0.6", alpha=0.5,
               label="measured points", rasterized=len(points) > RASTER_ABOVE_POINTS)
    cs = ax.contour(sg, tg, pg, levels=levels, colors="k", linewidths=0.7)
    ax.contour(sg, tg, pg, levels=[0.0], colors="k", linewidths=2.2)
    ax.clabel(cs, levels=levels[:: max(1, len(levels) // 8)], fontsize=7, fmt="%.0f")
    for _, group in points.groupby("quadrant"):
        if len(group) < 6:
            continue
        try:
            tri = Triangulation(group["speed_rpm"].to_numpy(float),
                                group["torque_nm"].to_numpy(float))
        except (ValueError, RuntimeError):
            continue
        p = group["p_elec_w"].to_numpy(float)
        ax.tricontour(tri, p, levels=levels, colors="tab:red", linewidths=0.6,
                      linestyles="dashed")
        if p.min() < 0.0 < p.max():
            ax.tricontour(tri, p, levels=[0.0], colors="tab:red", linewidths=2.0,
                          linestyles="dashed")
    ax.plot([], [], color="k", lw=0.7, label="fit (model)")
    ax.plot([], [], color="tab:red", lw=0.7, ls="--", label="measured (interpolated)")
    ax.set_xlabel("drum speed [rpm]")
    ax.set_ylabel("drum torque [N m]")
    ax.set_title(f"Electrical power [W], a contour every {POWER_CONTOUR_STEP_W:.0f} W, "
                 "zero line thick (+ = drawn from grid)", fontsize=9)
    ax.legend(loc="upper left", fontsize=7)
    return to_svg(fig, "power-map")


def _in_domain(model: PowerModel, speed_rpm: np.ndarray, torque_nm: np.ndarray) -> np.ndarray:
    """True where (speed, torque) lies in the model's validity domain (all True without one)."""
    if not model.domain:
        return np.ones(np.shape(speed_rpm), dtype=bool)
    xy = np.column_stack([np.ravel(speed_rpm), np.ravel(torque_nm)])
    inside = np.zeros(len(xy), dtype=bool)
    for polygon in model.domain.values():
        if len(polygon) >= 3:
            inside |= MplPath(np.asarray(polygon, float)).contains_points(xy, radius=1e-9)
    return inside.reshape(np.shape(speed_rpm))


def _levels(values: np.ndarray) -> np.ndarray:
    lo = np.floor(np.nanmin(values) / POWER_CONTOUR_STEP_W) * POWER_CONTOUR_STEP_W
    hi = np.ceil(np.nanmax(values) / POWER_CONTOUR_STEP_W) * POWER_CONTOUR_STEP_W
    return np.arange(lo, hi + POWER_CONTOUR_STEP_W / 2, POWER_CONTOUR_STEP_W)


def residual_figure(points: pd.DataFrame, residual_w: np.ndarray, nominal_power_w: float) -> Markup:
    """Residuals (measured minus model) against speed, against torque, and their histogram.

    Parameters
    ----------
    points : DataFrame
        Store points (``speed_rpm``, ``torque_nm``, ``quadrant``).
    residual_w : (n,) array
        Measured minus modelled electrical power per point [W].
    nominal_power_w : float
        Nominal power [W]; the ±5 % band of the paper's claim is drawn.
    """
    fig = new_figure(9.0, 3.2)
    axes = fig.subplots(1, 3)
    band = 0.05 * nominal_power_w
    for ax, col, label in (
        (axes[0], "speed_rpm", "drum speed [rpm]"),
        (axes[1], "torque_nm", "drum torque [N m]"),
    ):
        for quadrant, idx in points.groupby("quadrant").indices.items():
            ax.scatter(points[col].to_numpy(float)[idx], residual_w[idx], s=3, alpha=0.6,
                       color=QUADRANT_COLORS.get(str(quadrant), "grey"),
                       rasterized=len(points) > RASTER_ABOVE_POINTS)
        for sign in (-1, 1):
            ax.axhline(sign * band, color="tab:red", lw=0.8, ls="--")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel(label)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.set_ylabel("residual P_elec [W]")
        ax.grid(alpha=0.3)
    axes[0].set_title("dashed: ±5 % of nominal", fontsize=8)
    ax = axes[2]
    ax.hist(residual_w, bins=40, density=True, color="0.6")
    mu, sd = float(np.mean(residual_w)), float(np.std(residual_w, ddof=1))
    x = np.linspace(mu - 4 * sd, mu + 4 * sd, 200)
    ax.plot(x, np.exp(-0.5 * ((x - mu) / sd) ** 2) / (sd * np.sqrt(2 * np.pi)), "k-", lw=1,
            label="normal, same mean and sd")
    ax.set_xlabel("residual P_elec [W]")
    ax.set_ylabel("density [1/W]")
    ax.legend(fontsize=7)
    return to_svg(fig, "residuals")
