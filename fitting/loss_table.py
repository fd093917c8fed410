"""Loss table export: drive losses on a regular speed-torque grid, as mapped-motor blocks read.

Losses are ``loss_w = p_elec_w - p_mech_w`` (>= 0 for a real drive in both
quadrants with the sign convention of docs/schemas.md): in the motor quadrant
the grid supplies the shaft power plus the losses; in the generator quadrant
the grid receives the shaft power minus the losses.

File layout (CSV, ``#`` comment lines first)::

    # drivebench loss table ...             (model, hash, units, sign convention)
    speed_rpm \\ torque_nm,0,2,4,...,78        torque breakpoints [N m]
    -3000,<loss_w>,<loss_w>,...               one row per speed breakpoint [rpm]
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from fitting.domain import in_domain
from fitting.power_model import PowerModel
from kernel.files import write_text_atomic
from kernel.units import RPM_PER_RAD_S


def loss_grid(model: PowerModel, speeds_rpm: np.ndarray, torques_nm: np.ndarray) -> np.ndarray:
    """Losses [W] of ``model`` on the grid, shape (n_speeds, n_torques).

    Parameters
    ----------
    model : PowerModel
    speeds_rpm : numpy.ndarray
        Speed breakpoints [rpm], drum frame.
    torques_nm : numpy.ndarray
        Torque breakpoints [N m], drum frame.
    """
    s, t = np.meshgrid(speeds_rpm, torques_nm, indexing="ij")
    p_mech = s / RPM_PER_RAD_S * t
    return np.asarray(model.p_elec_w(s, t), dtype=float) - p_mech


def default_breakpoints(model: PowerModel, speed_step_rpm: float = 100.0,
                        torque_step_nm: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints [rpm], [N m] spanning the model's domain bounding box (else its drive's box).

    Raises
    ------
    ValueError
        The model has neither a domain nor a drive rating.
    """
    if model.domain:
        pts = np.array([p for poly in model.domain.values() for p in poly])
        s_lo, s_hi = pts[:, 0].min(), pts[:, 0].max()
        t_lo, t_hi = max(0.0, pts[:, 1].min()), pts[:, 1].max()
    elif model.drive is not None:
        s_hi, t_hi = model.drive.box()
        s_lo, t_lo = -s_hi, 0.0
    else:
        raise ValueError("the model has no domain and no drive rating: give the breakpoints")
    # ends rounded to the nearest breakpoint: a hull vertex at -3000.3 rpm (measurement
    # noise around a -3000 rpm set point) should not add a -3100 rpm row
    def axis(lo, hi, step):
        return np.arange(np.round(lo / step) * step, np.round(hi / step) * step + step / 2, step)

    return axis(s_lo, s_hi, speed_step_rpm), axis(t_lo, t_hi, torque_step_nm)


def write_loss_table(model: PowerModel, path: str | Path, speeds_rpm=None,
                     torques_nm=None) -> Path:
    """Write the loss table CSV atomically (layout in the module docstring).

    Every cell holds the model's loss; cells outside the measured domain
    (``model.domain``) are model extrapolation, and their share is stated in
    the header.
    """
    if speeds_rpm is None or torques_nm is None:
        speeds_rpm, torques_nm = default_breakpoints(model)
    speeds_rpm = np.asarray(speeds_rpm, dtype=float)
    torques_nm = np.asarray(torques_nm, dtype=float)
    losses = loss_grid(model, speeds_rpm, torques_nm)
    s, t = np.meshgrid(speeds_rpm, torques_nm, indexing="ij")
    inside = in_domain(model.domain, s, t)
    buf = io.StringIO()
    buf.write(f"# drivebench loss table from power model {model.name!r} (sha256 {model.sha256})\n")
    buf.write("# cells: loss_w = p_elec_w - p_mech_w [W]; rows: drum speed [rpm]; "
              "columns: drum torque [N m]\n")
    buf.write("# sign convention: positive electrical power is drawn from the grid, reel-out "
              "(generating) is negative speed, torque >= 0\n")
    if model.domain:
        buf.write(f"# {100 * (1 - inside.mean()):.1f} % of the cells lie outside the measured "
                  "envelope (power_model.json domain): there the table extrapolates the model\n")
    buf.write("speed_rpm \\ torque_nm," + ",".join(f"{v:g}" for v in torques_nm) + "\n")
    for k, speed in enumerate(speeds_rpm):
        buf.write(f"{speed:g}," + ",".join(f"{v:.3f}" for v in losses[k]) + "\n")
    return write_text_atomic(path, buf.getvalue())


def read_loss_table(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a loss table back: (speeds [rpm], torques [N m], losses [W])."""
    lines = [ln for ln in Path(path).read_text().splitlines() if not ln.startswith("#")]
    torques = np.array([float(v) for v in lines[0].split(",")[1:]])
    rows = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    return rows[:, 0], torques, rows[:, 1:]
