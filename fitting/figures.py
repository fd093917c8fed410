"""Figures of the fit (matplotlib, Agg): efficiency map (paper Fig. 5), power map
(paper Fig. 6), residuals.

The ``draw_*`` functions draw on axes they are given, so ``bench fit`` (files) and
``bench report`` (inline SVG, :mod:`reports.drive_figures`) show the same figures.
The ``*_figure`` functions write a figure as PNG and SVG with the data it draws
beside it as Parquet (``<name>.png``, ``<name>.svg``, ``<name>.parquet``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

from fitting.domain import in_domain  # noqa: E402
from fitting.efficiency import ABOVE_MAX, CLIPPED, NEAR_AXIS  # noqa: E402
from kernel.figure_text import fit_text  # noqa: E402
from kernel.files import atomic_write, write_parquet  # noqa: E402

#: Contour spacing of the power map [W] (paper Fig. 6: a line every 500 W).
POWER_CONTOUR_STEP_W = 500.0
#: Efficiency levels outlined on the map [-].
EFFICIENCY_CONTOURS = (0.5, 0.7, 0.8, 0.85, 0.9)
#: Map nodes the masking rules blank (drawn white like a negative efficiency, as in
#: the paper); nodes outside the measured envelope are NaN and not drawn.
MASKED_STATUSES = (NEAR_AXIS, ABOVE_MAX)
#: Colour of the measured envelope's outline: none of the scenario kinds' colours
#: (:data:`optimize.plots.SCENARIO_COLORS`), so Fig. 9's cycles stay apart from it.
ENVELOPE_COLOR = "#e377c2"
#: Colours of the two quadrants.
QUADRANT_COLORS = {"motor": "#1f77b4", "generator": "#2ca02c"}
#: Above this many points, scatter layers are drawn as a bitmap (small SVG files).
RASTER_ABOVE_POINTS = 2000
#: Model grid of the power map: nodes in speed and torque.
POWER_GRID_NODES = (241, 121)


def efficiency_colormap() -> ListedColormap:
    """Viridis with efficiency 0 (masked or negative, paper: white) drawn white."""
    import matplotlib as mpl

    colors = mpl.colormaps["viridis"].resampled(256)(np.linspace(0, 1, 256))
    colors[0] = (1.0, 1.0, 1.0, 1.0)
    return ListedColormap(colors, name="eta_white_zero")


def efficiency_grid(map_frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pivot the long efficiency map into ``(speed_rpm (n,), torque_nm (m,), eta (m, n))``.

    Negative efficiencies and nodes of :data:`MASKED_STATUSES` become 0 (white);
    nodes outside the measured envelope stay NaN.
    """
    eta = map_frame["eta"].to_numpy(float).copy()
    eta[eta < 0] = 0.0
    if "status" in map_frame.columns:
        eta[map_frame["status"].astype(str).isin(MASKED_STATUSES).to_numpy()] = 0.0
    frame = pd.DataFrame({"speed_rpm": map_frame["speed_rpm"],
                          "torque_nm": map_frame["torque_nm"], "eta": eta})
    table = frame.pivot_table(index="torque_nm", columns="speed_rpm", values="eta",
                              aggfunc="first", dropna=False)
    return table.columns.to_numpy(float), table.index.to_numpy(float), table.to_numpy(float)


def draw_efficiency(ax, speed_rpm, torque_nm, eta, colorbar: bool = True):
    """Draw an efficiency grid on ``ax`` (0 white, NaN not drawn); returns the mesh."""
    mesh = ax.pcolormesh(speed_rpm, torque_nm, np.ma.masked_invalid(eta),
                         cmap=efficiency_colormap(), vmin=0.0, vmax=1.0, shading="nearest",
                         rasterized=True)
    if colorbar:
        ax.figure.colorbar(mesh, ax=ax, label="efficiency [-] (paper eqs. 1, 2)")
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel("drum speed [rpm] (generator: reel-out < 0 < motor)")
    ax.set_ylabel("drum torque [N m]")
    return mesh


def draw_efficiency_map(ax, map_frame: pd.DataFrame, domain: dict | None = None,
                        masking: dict | None = None) -> None:
    """The measured efficiency map (paper Fig. 5) on ``ax``.

    Parameters
    ----------
    map_frame : DataFrame
        The long map of ``efficiency_map.parquet``: ``speed_rpm``, ``torque_nm``,
        ``eta`` and, when present, ``status`` (nodes clipped to the quadrant's
        efficiency ceiling are marked).
    domain : dict, optional
        ``quadrant -> polygon`` of the model's validity domain, outlined.
    masking : dict, optional
        The masking rules (``mech_frac``, ``elec_frac`` of nominal power), named in the legend.
    """
    speeds, torques, eta = efficiency_grid(map_frame)
    draw_efficiency(ax, speeds, torques, eta)
    if np.isfinite(eta).sum() >= 4 and len(speeds) > 1 and len(torques) > 1:
        cs = ax.contour(speeds, torques, np.ma.masked_invalid(eta), levels=EFFICIENCY_CONTOURS,
                        colors="k", linewidths=0.5)
        ax.clabel(cs, fontsize=7, fmt="%.2f")
    for k, poly in enumerate((domain or {}).values()):
        p = np.asarray(poly, dtype=float)
        ax.plot(np.r_[p[:, 0], p[:1, 0]], np.r_[p[:, 1], p[:1, 1]], color=ENVELOPE_COLOR,
                lw=0.8, label="measured envelope" if k == 0 else None, gid="measured-envelope")
    clipped = (map_frame[map_frame["status"] == CLIPPED] if "status" in map_frame.columns
               else map_frame.iloc[:0])
    if len(clipped):
        ax.scatter(clipped["speed_rpm"], clipped["torque_nm"], s=4, marker="x", c="k",
                   lw=0.5, label=f"clipped to measured max + noise ({len(clipped)} nodes)")
    # what white and blank mean, in the legend: a short title fits over a panel of a
    # figure of several (the contours carry their own labels)
    rule = (f": |P_mech| < {masking['mech_frac']:g} P_nom or |P_elec| < "
            f"{masking['elec_frac']:g} P_nom" if masking else " near the axes")
    ax.fill([], [], facecolor="white", edgecolor="0.5", lw=0.5,
            label=f"white: negative, or masked{rule}")
    ax.fill([], [], facecolor="none", edgecolor="none", label="blank: not measured")
    ax.legend(loc="upper left", fontsize=7)
    ax.set_title("Measured efficiency", fontsize=9)


def power_contour_levels(values: np.ndarray) -> np.ndarray:
    """Every :data:`POWER_CONTOUR_STEP_W` over the range of ``values`` [W]."""
    lo = np.floor(np.nanmin(values) / POWER_CONTOUR_STEP_W) * POWER_CONTOUR_STEP_W
    hi = np.ceil(np.nanmax(values) / POWER_CONTOUR_STEP_W) * POWER_CONTOUR_STEP_W
    return np.arange(lo, hi + POWER_CONTOUR_STEP_W / 2, POWER_CONTOUR_STEP_W)


def power_grid(model, points: pd.DataFrame) -> pd.DataFrame:
    """The model's electrical power on a grid over the measured points, NaN outside the
    model's validity domain (:func:`fitting.domain.in_domain`)."""
    sg, tg = np.meshgrid(
        np.linspace(float(points["speed_rpm"].min()), float(points["speed_rpm"].max()),
                    POWER_GRID_NODES[0]),
        np.linspace(0.0, float(points["torque_nm"].max()), POWER_GRID_NODES[1]))
    p = np.where(in_domain(model.domain, sg, tg), model.p_elec_w(sg, tg), np.nan)
    return pd.DataFrame({"speed_rpm": sg.ravel(), "torque_nm": tg.ravel(),
                         "p_elec_fit_w": np.asarray(p, float).ravel()})


def draw_power_map(ax, model, points: pd.DataFrame) -> pd.DataFrame:
    """Fit against measured electrical power (paper Fig. 6) on ``ax``; returns the model grid.

    Solid black: the model inside its validity domain; dashed red: contours of the
    measured points, triangulated per quadrant (no contour crosses the unmeasured
    gap between them). A contour every :data:`POWER_CONTOUR_STEP_W`, the zero line thick.

    Parameters
    ----------
    model : fitting.power_model.PowerModel
    points : DataFrame
        Operating points (``speed_rpm``, ``torque_nm``, ``p_elec_w``, ``quadrant``).
    """
    grid = power_grid(model, points)
    shape = POWER_GRID_NODES[::-1]
    sg, tg, pg = (grid[c].to_numpy(float).reshape(shape)
                  for c in ("speed_rpm", "torque_nm", "p_elec_fit_w"))
    levels = power_contour_levels(np.concatenate([pg[np.isfinite(pg)],
                                                  points["p_elec_w"].to_numpy(float)]))
    ax.scatter(points["speed_rpm"], points["torque_nm"], s=3, color="0.6", alpha=0.5,
               label="measured points", rasterized=len(points) > RASTER_ABOVE_POINTS)
    # solid below zero too: dashed lines are the measured contours
    cs = ax.contour(sg, tg, pg, levels=levels, colors="k", linewidths=0.7,
                    negative_linestyles="solid")
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
    return grid


def draw_residuals(axes, points: pd.DataFrame, residual_w: np.ndarray,
                   nominal_power_w: float) -> None:
    """Residuals (measured minus model) against speed, against torque, and their
    histogram with the normal of the same mean and standard deviation, on three axes.

    Parameters
    ----------
    axes : sequence of 3 Axes
    points : DataFrame
        Operating points (``speed_rpm``, ``torque_nm``, ``quadrant``).
    residual_w : (n,) array
        Measured minus modelled electrical power per point [W].
    nominal_power_w : float
        Nominal power [W]; the band of +-5 % of it (the paper's bound) is drawn.
    """
    r = np.asarray(residual_w, dtype=float)
    band = 0.05 * nominal_power_w
    for ax, col, label in ((axes[0], "speed_rpm", "drum speed [rpm]"),
                           (axes[1], "torque_nm", "drum torque [N m]")):
        for quadrant, idx in points.groupby("quadrant").indices.items():
            ax.scatter(points[col].to_numpy(float)[idx], r[idx], s=3, alpha=0.6,
                       color=QUADRANT_COLORS.get(str(quadrant), "grey"), label=str(quadrant),
                       rasterized=len(points) > RASTER_ABOVE_POINTS)
        for sign in (-1, 1):
            ax.axhline(sign * band, color="tab:red", lw=0.8, ls="--")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel(label)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.set_ylabel("residual P_elec [W]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[0].set_title("dashed: ±5 % of nominal power", fontsize=8)
    ax = axes[2]
    ax.hist(r, bins=40, density=True, color="0.6")
    mu, sd = float(np.mean(r)), float(np.std(r, ddof=1)) if r.size > 1 else float("nan")
    if np.isfinite(sd) and sd > 0:
        x = np.linspace(mu - 4 * sd, mu + 4 * sd, 200)
        ax.plot(x, np.exp(-0.5 * ((x - mu) / sd) ** 2) / (sd * np.sqrt(2 * np.pi)), "k-", lw=1,
                label="normal, same mean and sd")
        ax.legend(fontsize=7)
    ax.set_xlabel("residual P_elec [W]")
    ax.set_ylabel("density [1/W]")
    ax.set_title(f"mean {mu:.1f} W, sd {100 * sd / nominal_power_w:.2f} % of nominal",
                 fontsize=8)


# ------------------------------------------------------------------ files of bench fit
def _save(fig: Figure, out_dir: Path, name: str, data: pd.DataFrame) -> list[Path]:
    fit_text(fig)  # no title or label cut off at the figure's edges
    paths = [atomic_write(out_dir / f"{name}.{fmt}",
                          lambda p, fmt=fmt: fig.savefig(p, format=fmt, dpi=120))
             for fmt in ("png", "svg")]
    paths.append(write_parquet(out_dir / f"{name}.parquet", data))
    return paths


def efficiency_map_figure(map_frame: pd.DataFrame, out_dir: Path, masking: dict | None = None,
                          domain: dict | None = None) -> list[Path]:
    """Write the efficiency map (:func:`draw_efficiency_map`) into ``out_dir``."""
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    draw_efficiency_map(fig.add_subplot(), map_frame, domain, masking)
    data = map_frame[["speed_rpm", "torque_nm", "quadrant", "eta", "status"]]
    return _save(fig, out_dir, "efficiency_map", data)


def power_map_figure(model, points: pd.DataFrame, out_dir: Path) -> list[Path]:
    """Write the power map (:func:`draw_power_map`) into ``out_dir``; its data file holds
    the model grid it contours."""
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    grid = draw_power_map(fig.add_subplot(), model, points)
    return _save(fig, out_dir, "power_map", grid)


def residuals_figure(points: pd.DataFrame, residuals_w: np.ndarray, nominal_power_w: float,
                     out_dir: Path) -> list[Path]:
    """Write the residual figure (:func:`draw_residuals`) into ``out_dir``."""
    fig = Figure(figsize=(11, 3.6), layout="constrained")
    draw_residuals(fig.subplots(1, 3), points, residuals_w, nominal_power_w)
    data = pd.DataFrame({
        "session_id": points["session_id"].to_numpy(),
        "point_id": points["point_id"].to_numpy(),
        "quadrant": points["quadrant"].to_numpy(),
        "speed_rpm": points["speed_rpm"].to_numpy(),
        "torque_nm": points["torque_nm"].to_numpy(),
        "residual_w": np.asarray(residuals_w, dtype=float),
    })
    return _save(fig, out_dir, "residuals", data)
