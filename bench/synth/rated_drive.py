"""A drive with a known truth for any rating: a power-limited envelope and a loss model.

The envelope is that of a real traction or winch drive: full torque up to the
base speed, constant power above it (torque ~ 1 / speed), so it is not convex.
The loss is a smooth function of the normalised speed and torque, scaled with
the nominal power (friction, iron and copper terms)::

    loss_w = P_nom * (a0 + a1 x + a2 x^2 + a3 y^2),  x = |n| / n_max, y = T / T_max

The drum frame of docs/schemas.md holds: torque >= 0, generating is negative speed,
``P_elec = P_mech + loss`` in both quadrants.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd

from kernel.drive import Drive
from kernel.units import RPM_PER_RAD_S


@dataclass(frozen=True)
class TruthDrive:
    """A drive with known losses: its rating and its true loss coefficients (fractions of
    nominal power).

    Parameters
    ----------
    rating : kernel.drive.Drive
        Nominal (and constant-power) power, drum speed and torque limits, and the
        envelope: full torque up to the base speed ``P_nom / T_max``, constant power above
        it (:meth:`rated`).
    loss_fracs : tuple of float
        ``(a0, a1, a2, a3)`` of the loss model [-].
    """

    rating: Drive
    loss_fracs: tuple[float, float, float, float] = (0.004, 0.006, 0.010, 0.030)

    @classmethod
    def rated(cls, nominal_power_w: float, max_speed_rpm: float, torque_nm: float
              ) -> TruthDrive:
        """The drive of nominal power [W], speed limit [rpm] and torque limit [N m], its
        torque constant up to the base speed ``P_nom / T_max`` and falling as ``P_nom / w``
        above it."""
        return cls(Drive.rating(nominal_power_w, max_speed_rpm, torque_nm,
                                base_speed_rpm=nominal_power_w / torque_nm * RPM_PER_RAD_S,
                                source="bench.synth.rated_drive"))

    def loss_w(self, speed_rpm, torque_nm) -> np.ndarray:
        """True loss [W]."""
        a0, a1, a2, a3 = self.loss_fracs
        speed_top, torque_top = self.rating.box()
        x = np.abs(np.asarray(speed_rpm, dtype=float)) / speed_top
        y = np.asarray(torque_nm, dtype=float) / torque_top
        return self.rating.nominal_power_w * (a0 + a1 * x + a2 * x**2 + a3 * y**2)

    def p_elec_w(self, speed_rpm, torque_nm) -> np.ndarray:
        """True electrical power [W] (positive drawn from the grid)."""
        p_mech = np.asarray(speed_rpm, float) / RPM_PER_RAD_S * np.asarray(torque_nm, float)
        return p_mech + self.loss_w(speed_rpm, torque_nm)

    def eta(self, speed_rpm, torque_nm) -> np.ndarray:
        """True efficiency by paper eqs. 1 and 2 [-]."""
        p_mech = np.asarray(speed_rpm, float) / RPM_PER_RAD_S * np.asarray(torque_nm, float)
        p_elec = self.p_elec_w(speed_rpm, torque_nm)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(p_mech > 0, p_mech / p_elec, p_elec / p_mech)


#: The 150 kW, 12000 rpm class of the EV export (base speed 4000 rpm).
EV_DRIVE = TruthDrive.rated(150_000.0, 12_000.0, 150_000.0 / (4000.0 / RPM_PER_RAD_S))
#: The paper's 8.2 kW drive rating with the same loss shape.
PAPER_DRIVE = TruthDrive.rated(8200.0, 1500.0, 78.0)


def grid_points(drive: TruthDrive, quadrants=("motor", "generator"), *, n_speeds: int = 24,
                n_torques: int = 12, noise_w: float = 0.0, seed: int = 0,
                min_speed_frac: float = 0.04, min_torque_frac: float = 0.03) -> pd.DataFrame:
    """Operating points on a jittered set-point grid inside the true envelope.

    At each speed level the torque steps from ``min_torque_frac * T_max`` to the
    envelope at that speed, as a bench operator does; speeds run from
    ``min_speed_frac * n_max`` to ``n_max`` (negative in the generator quadrant).

    Returns
    -------
    pandas.DataFrame
        Store-like points (docs/schemas.md §2): ``session_id, point_id, mode,
        quadrant, source, speed_rpm, torque_nm, p_mech_w, p_elec_w``; the true
        electrical power is in ``p_elec_true_w``.
    """
    rng = np.random.default_rng(seed)
    frames = []
    speed_top, torque_top = drive.rating.box()
    for q in quadrants:
        step = (1.0 - min_speed_frac) * speed_top / (n_speeds - 1)
        levels = min_speed_frac * speed_top + step * np.arange(n_speeds)
        levels = np.clip(levels + rng.uniform(-0.1, 0.1, n_speeds) * step,
                         min_speed_frac * speed_top, speed_top)
        s, t = [], []
        for n in levels:
            top = float(drive.rating.largest_torque_nm(n))
            s.append(np.full(n_torques, n))
            t.append(np.linspace(min_torque_frac * torque_top, top, n_torques))
        speed = np.concatenate(s) * (1.0 if q == "motor" else -1.0)
        torque = np.concatenate(t)
        p_mech = speed / RPM_PER_RAD_S * torque
        p_true = drive.p_elec_w(speed, torque)
        frames.append(pd.DataFrame({
            "session_id": f"{q}_01", "point_id": np.arange(speed.size, dtype="int32"),
            "mode": q, "quadrant": q, "source": "operating_point_table",
            "speed_rpm": speed, "torque_nm": torque, "p_mech_w": p_mech,
            "p_elec_w": p_true + rng.normal(0.0, noise_w, speed.size),
            "p_elec_true_w": p_true,
        }))
    return pd.concat(frames, ignore_index=True)


def write_table_campaign(folder, drive: TruthDrive, points: pd.DataFrame,
                         source: str = "synthetic rated drive (bench.synth.rated_drive)",
                         base_speed_rpm: float | None = None) -> None:
    """Write points as a campaign of operating-point-table sessions plus its ``drive.toml``.

    One session per ``session_id`` of ``points`` (docs/schemas.md §1: ``session.toml``
    of kind ``operating_points``, ``points.csv`` with foreign column names and units,
    ``mapping.toml``), sensor ranges 25 % above the drive's rating.

    Parameters
    ----------
    folder : str or Path
        Campaign folder (created).
    drive : TruthDrive
    points : pandas.DataFrame
        As :func:`grid_points` returns.
    source : str
        The ``source`` line of ``drive.toml``.
    base_speed_rpm : float, optional
        A torque-speed envelope for ``drive.toml`` to state (constant power above it).
    """
    from pathlib import Path

    from kernel.drive_file import DRIVE_FILE, drive_toml
    from kernel.files import write_text_atomic

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rating = dataclasses.replace(drive.rating, source=source, base_speed_rpm=base_speed_rpm)
    speed_top, torque_top = rating.box()
    write_text_atomic(folder / DRIVE_FILE, drive_toml(rating))
    for sid, sub in points.groupby("session_id"):
        session = folder / str(sid)
        session.mkdir(exist_ok=True)
        mode = str(sub["mode"].iloc[0])
        write_text_atomic(session / "session.toml", "\n".join([
            f'session_id = "{sid}"', 'kind = "operating_points"', f'mode = "{mode}"',
            'operator = "bench.synth.rated_drive"', 'date = "2026-01-01"', "gear_ratio = 1.0",
            'measured_side = "drum"', "speed_sign = 1", "torque_sign = 1", "",
            "[points]", 'file = "points.csv"', 'mapping = "mapping.toml"', "",
            "[sensors]", f"torque_range_nm = {1.25 * torque_top!r}",
            f"speed_range_rpm = {1.25 * speed_top!r}",
            f"power_range_w = {1.25 * rating.nominal_power_w!r}", ""]))
        write_text_atomic(session / "mapping.toml", "\n".join([
            "[columns.speed]", 'column = "n"', 'unit = "1/min"', "",
            "[columns.torque]", 'column = "M"', 'unit = "Nm"', "",
            "[columns.p_elec]", 'column = "P_el"', 'unit = "kW"', ""]))
        table = pd.DataFrame({"n": sub["speed_rpm"].round(3), "M": sub["torque_nm"].round(4),
                              "P_el": (sub["p_elec_w"] / 1000.0).round(6)})
        write_text_atomic(session / "points.csv", table.to_csv(index=False))
