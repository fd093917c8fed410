"""Figures of the fit (matplotlib, Agg): efficiency map, power map, residuals.

Each figure is written as PNG and SVG, with the data it draws beside it as
Parquet (``<name>.png``, ``<name>.svg``, ``<name>.parquet``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy import stats  # noqa: E402

from bench.files import atomic_write  # noqa: E402
from fitting.outputs import write_parquet  # noqa: E402

#: Contour spacing of the power map (paper Fig. 6) [W].
POWER_CONTOUR_STEP_W = 500.0


def _save(fig, out_dir: Path, name: str, data: pd.DataFrame) -> list[Path]:
    paths = []
    for fmt in ("png", "svg"):
        paths.append(atomic_write(out_dir / f"{name}.{fmt}",
                                  lambda p, fmt=fmt: fig.savefig(p, format=fmt, dpi=120)))
    plt.close(fig)
    paths.append(write_parquet(out_dir / f"{name}.parquet", data))
    return paths


def _grid(map_frame: pd.DataFrame, column: str):
    speeds = np.unique(map_frame["speed_rpm"])
    torques = np.unique(map_frame["torque_nm"])
    z = map_frame.pivot(index="torque_nm", columns="speed_rpm", values=column)
    return speeds, torques, z.reindex(index=torques, columns=speeds).to_numpy(dtype=float)


def efficiency_map_figure(map_frame: pd.DataFrame, out_dir: Path, masking: dict,
                          domain: dict | None = None) -> list[Path]:
    """Efficiency over the measured quadrants (paper Fig. 5); masked and negative values white.

    ``domain`` (quadrant -> envelope polygon) is outlined; nodes clipped to the
    quadrant's efficiency ceiling are hatched.
    """
    speeds, torques, eta = _grid(map_frame, "eta")
    shown = np.ma.masked_where(~np.isfinite(eta) | (eta <= 0), eta)
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    cmap = plt.get_cmap("viridis").with_extremes(bad="white")
    mesh = ax.pcolormesh(speeds, torques, shown, cmap=cmap, vmin=0, vmax=1, shading="nearest",
                         rasterized=True)
    levels = [0.5, 0.7, 0.8, 0.85, 0.9]
    cs = ax.contour(speeds, torques, np.where(np.isfinite(eta), eta, np.nan), levels=levels,
                    colors="k", linewidths=0.6)
    ax.clabel(cs, fmt="%.2f", fontsize=7)
    ax.axvline(0, color="0.3", lw=0.8)
    for q, poly in (domain or {}).items():
        p = np.asarray(poly, dtype=float)
        ax.plot(np.r_[p[:, 0], p[:1, 0]], np.r_[p[:, 1], p[:1, 1]], color="tab:red", lw=0.8,
                label=f"measured envelope ({q})" if q == next(iter(domain)) else None)
    clipped = map_frame[map_frame["status"] == "clipped"]
    if len(clipped):
        ax.scatter(clipped["speed_rpm"], clipped["torque_nm"], s=4, marker="x", c="k",
                   lw=0.5, label=f"clipped to measured max + noise ({len(clipped)} nodes)")
    if domain or len(clipped):
        ax.legend(loc="upper left", fontsize=7)
    fig.colorbar(mesh, ax=ax, label="efficiency [-]")
    ax.set_xlabel("drum speed [rpm]  (generator: reel-out < 0 | motor > 0)")
    ax.set_ylabel("drum torque [N m]")
    ax.set_title("Measured efficiency map (white: negative, near the axes, or outside the "
                 "measured envelope)\n"
                 f"masked: |P_mech| < {masking['mech_frac']:g} P_nom, "
                 f"|P_elec| < {masking['elec_frac']:g} P_nom", fontsize=9)
    data = map_frame[["speed_rpm", "torque_nm", "quadrant", "eta", "status"]]
    return _save(fig, out_dir, "efficiency_map", data)


def power_map_figure(map_frame: pd.DataFrame, points: pd.DataFrame, out_dir: Path) -> list[Path]:
    """Electrical power map, fit (solid) against measured (dashed), contours every 500 W,
    zero line thicker (paper Fig. 6)."""
    speeds, torques, fit = _grid(map_frame, "p_elec_fit_w")
    _, _, meas = _grid(map_frame, "p_elec_w")
    lo = np.floor(np.nanmin([np.nanmin(fit), np.nanmin(meas)]) / POWER_CONTOUR_STEP_W)
    hi = np.ceil(np.nanmax([np.nanmax(fit), np.nanmax(meas)]) / POWER_CONTOUR_STEP_W)
    levels = np.arange(lo, hi + 1) * POWER_CONTOUR_STEP_W
    widths = [2.5 if v == 0 else 0.7 for v in levels]
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    ax.scatter(points["speed_rpm"], points["torque_nm"], s=3, c="0.8", label="operating points",
               rasterized=True)
    cf = ax.contour(speeds, torques, fit, levels=levels, colors="tab:blue", linewidths=widths,
                    negative_linestyles="solid")
    cm = ax.contour(speeds, torques, meas, levels=levels, colors="tab:red", linewidths=widths,
                    linestyles="dashed")
    ax.clabel(cf, levels=levels[::4], fmt="%.0f W", fontsize=6)
    ax.plot([], [], color="tab:blue", label="fit")
    ax.plot([], [], color="tab:red", ls="--", label="measured (inside the envelope)")
    del cm
    ax.legend(loc="upper left", fontsize=7)
    ax.set_xlabel("drum speed [rpm]")
    ax.set_ylabel("drum torque [N m]")
    ax.set_title(f"Electrical power [W], contours every {POWER_CONTOUR_STEP_W:.0f} W, "
                 "zero line thick (positive: drawn from grid)", fontsize=9)
    data = map_frame[["speed_rpm", "torque_nm", "p_elec_w", "p_elec_fit_w"]]
    return _save(fig, out_dir, "power_map", data)


def residuals_figure(points: pd.DataFrame, residuals_w: np.ndarray, nominal_power_w: float,
                     out_dir: Path) -> list[Path]:
    """Residuals (measured - fit) against speed, against torque, and their histogram."""
    r = np.asarray(residuals_w, dtype=float)
    pct = 100.0 / nominal_power_w
    colors = np.where(points["quadrant"].to_numpy() == "motor", "tab:orange", "tab:green")
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.6), constrained_layout=True)
    for ax, col, label in ((axes[0], "speed_rpm", "drum speed [rpm]"),
                           (axes[1], "torque_nm", "drum torque [N m]")):
        ax.scatter(points[col], r, s=3, c=colors, rasterized=True)
        ax.axhline(0, color="k", lw=0.8)
        for sign in (-1, 1):
            ax.axhline(sign * 5.0 / pct, color="tab:red", lw=0.8, ls=":")
        ax.set_xlabel(label)
        ax.set_ylabel("residual P_elec [W]")
    axes[0].set_title("orange: motor, green: generator; dotted: 5 % of nominal", fontsize=8)
    ax = axes[2]
    ax.hist(r, bins=40, density=True, color="0.6")
    x = np.linspace(r.min(), r.max(), 200)
    ax.plot(x, stats.norm.pdf(x, r.mean(), r.std(ddof=1)), color="k", lw=1)
    ax.set_xlabel("residual P_elec [W]")
    ax.set_ylabel("density [1/W]")
    ax.set_title(f"mean {r.mean():.1f} W, std {r.std(ddof=1) * pct:.2f} % of nominal", fontsize=8)
    data = pd.DataFrame({
        "session_id": points["session_id"].to_numpy(),
        "point_id": points["point_id"].to_numpy(),
        "quadrant": points["quadrant"].to_numpy(),
        "speed_rpm": points["speed_rpm"].to_numpy(),
        "torque_nm": points["torque_nm"].to_numpy(),
        "residual_w": r,
    })
    return _save(fig, out_dir, "residuals", data)
