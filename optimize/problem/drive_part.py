"""The drivetrain and the drive as a part of the cycle OCP (paper eq. 4).

No variables of its own: from the kite's tension and reel motion it derives the motor
speed, the drive's shaft torque (with the drivetrain's inertia), the shaft and the
electrical power; its rows are the drive's limits (torque, envelope, electrical power;
the ``*-lim`` kinds) and the kite's tether-force limit at the drum; its averages the
cycle's electrical and mechanical power and the squared torque of an RMS rating.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from kernel.drive import DriveModel
from kernel.units import RPM_PER_RAD_S
from optimize.model.drivetrain import Drivetrain, max_reel_speed_m_s
from optimize.model.envelope import (
    EnvelopeTable,
    envelope_torque_nm,
)
from optimize.problem.interface import Row
from optimize.problem.kite_part import reel_speed_range_m_s
from optimize.problem.part import ACTIVE_RTOL, Part, near
from optimize.problem.scaling import Scales

#: the cycle averages: electrical and mechanical power drawn [W], and the squared motor
#: torque over its scale (the RMS-torque rating's integrand)
AVERAGES = ("p_elec_w", "p_mech_w", "torque_sq")
#: the averages a scenario's objective can weight (``optimize.kinds.Objective.average``)
OBJECTIVE_AVERAGES = ("p_elec_w", "p_mech_w")


@dataclass(frozen=True)
class DrivePart(Part):
    """Drum, gearbox, rotor and the drive's power model (a :class:`Part`).

    Parameters
    ----------
    drivetrain : Drivetrain
    drive_model : DriveModel
        Electrical power model of the drive.
    system : optimize.system.system.System
        Its inputs: the ``[drive]`` in force (:meth:`optimize.system.system.System.in_force`:
        the rating, the envelope), and the kite's tether-force limit and tension floor it
        holds at the drum, the winch's reel speeds within the drive's.
    scales_of : Scales
        Its ``power_w`` and ``torque_nm``.
    rms_torque_nm : float or None
        The RMS-torque rating as a row on the cycle average (None: no row; a thermal
        rating replaces it).
    """

    drivetrain: Drivetrain
    drive_model: DriveModel
    system: Any
    scales_of: Scales
    rms_torque_nm: float | None = None
    name: str = "drive"
    output_columns: tuple[str, ...] = ("speed_rpm", "torque_nm", "tether_torque_nm",
                                       "tension_n", "p_mech_w", "p_elec_w")
    cycle_averages: tuple[str, ...] = AVERAGES
    objective_averages: tuple[str, ...] = OBJECTIVE_AVERAGES

    def quantities(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Motor speed, shaft and tether torque at the motor, shaft and electrical power."""
        dt, tension = self.drivetrain, q["tension_n"]
        dl, ddl = q["dl_m_s"], q["ddl_m_s2"]
        speed = dt.speed_rpm(dl)
        torque = dt.shaft_torque_nm(tension, ddl)
        return {"speed_rpm": speed, "torque_nm": torque,
                "tether_torque_nm": dt.tether_torque_nm(tension),
                "p_mech_w": dt.shaft_power_w(tension, dl, ddl),
                "p_elec_w": self.drive_model.casadi_p_elec_w(speed, torque)}

    @property
    def limits(self) -> dict[str, Any]:
        """The system's bounds by the names ``active_bounds`` reports them by
        (:meth:`optimize.system.system.System.bound_values`)."""
        return self.system.bound_values()

    @property
    def drive(self) -> Any:
        """The ``[drive]`` in force (:class:`kernel.drive.Drive`)."""
        return self.system.drive

    def tether_torque_limit_nm(self) -> float:
        """The kite's tether-force limit as a torque at the motor [N m] (inf: none)."""
        force = self.limits["tether_force_limit"]
        return np.inf if force is None else float(self.drivetrain.tether_torque_nm(force))

    def tether_torque_floor_nm(self) -> float:
        """The kite's tension floor as a torque at the motor [N m] (-inf: none)."""
        force = self.limits["tension_min"]
        return -np.inf if force is None else float(self.drivetrain.tether_torque_nm(force))

    def torque_rows(self, q: Mapping[str, Any]) -> list[Row]:
        """Rows on the drive's shaft torque and the tether's.

        Massless drivetrain: one row, the shaft torque (the tether's) between the kite's
        tension floor and its tether-force limit in every kind and below the drive's
        torque limit in the ``*-lim`` kinds. With inertia the shaft torque also goes
        negative (braking a reel-in), so the drive's limit bounds it both ways, and the
        tension floor and the tether-force limit have a row of their own on the tether
        torque.
        """
        sc, lim, torque = self.scales_of, self.drive, q["torque_nm"]
        torque_top = self.tether_torque_limit_nm()
        floor = self.tether_torque_floor_nm() / sc.torque_nm
        if self.drivetrain.inertia_kg_m2 == 0:
            return [Row("torque", torque / sc.torque_nm, floor, torque_top / sc.torque_nm,
                        limited=(floor, min(lim.max_torque_nm, torque_top) / sc.torque_nm))]
        top = lim.max_torque_nm / sc.torque_nm
        rows = [Row("torque", torque / sc.torque_nm, -np.inf, np.inf, limited=(-top, top))]
        if np.isfinite(torque_top) or np.isfinite(floor):
            rows.append(Row("tether_force", q["tether_torque_nm"] / sc.torque_nm, floor,
                            torque_top / sc.torque_nm))
        return rows

    def envelope_rows(self, q: Mapping[str, Any]) -> list[Row]:
        """The drive's torque-speed envelope in the ``*-lim`` kinds (none without one):
        ``|T w| <= T_max w_base`` above a base speed, or the table's largest torque."""
        lim, sc = self.drive, self.scales_of
        speed_rpm, torque = q["speed_rpm"], q["torque_nm"]
        if lim.base_speed_rpm is not None:
            power = lim.constant_power_w()
            return [Row("envelope", torque * speed_rpm / RPM_PER_RAD_S / power, -np.inf,
                        np.inf, limited=(-1.0, 1.0))]
        if lim.envelope_speed_rpm is None:
            return []
        top = EnvelopeTable(lim.envelope_speed_rpm, lim.envelope_torque_nm
                            ).smooth_torque_nm(speed_rpm)
        return [Row("envelope", ca.vertcat(torque - top, -torque - top) / sc.torque_nm,
                    -np.inf, np.inf, limited=(-np.inf, 0.0))]

    def rows(self, q: Mapping[str, Any]) -> list[Row]:
        """Torque, envelope and electrical-power rows."""
        rows = [*self.torque_rows(q), *self.envelope_rows(q)]
        if self.drive.max_p_elec_w is not None:
            p_lim = self.drive.max_p_elec_w / self.scales_of.power_w
            rows.append(Row("p_elec", q["p_elec_w"] / self.scales_of.power_w, -np.inf, np.inf,
                            limited=(-p_lim, p_lim)))
        return rows

    def averages(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Electrical and shaft power [W], squared torque over its scale."""
        return {"p_elec_w": q["p_elec_w"], "p_mech_w": q["p_mech_w"],
                "torque_sq": (q["torque_nm"] / self.scales_of.torque_nm) ** 2}

    def outputs(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Motor speed, shaft and tether torque, tension, shaft and electrical power."""
        return {name: q[name] for name in self.output_columns}

    def constrained_averages(self) -> tuple[str, ...]:
        """The squared torque when the drive has an RMS-torque rating."""
        return () if self.rms_torque_nm is None else ("torque_sq",)

    def average_rows(self, averages: Mapping[str, Any]) -> list[Row]:
        """The RMS-torque rating in the ``*-lim`` kinds."""
        if self.rms_torque_nm is None:
            return []
        return [Row("rms_torque", averages["torque_sq"], -np.inf, np.inf,
                    limited=(-np.inf, (self.rms_torque_nm / self.scales_of.torque_nm) ** 2))]

    def active_bounds(self, traj: Any, drive_limits: bool) -> list[str]:
        """The kite's tether-force limit (every kind); the drive's speed, torque, envelope
        and electrical-power limits (the ``*-lim`` kinds)."""
        lim = self.limits
        out = ["tether_force_limit"] if near(traj["tension_n"], lim["tether_force_limit"]) else []
        if not drive_limits:
            return out
        speed, torque = np.abs(np.asarray(traj["speed_rpm"])), np.abs(np.asarray(traj["torque_nm"]))
        checks = (("speed_limit", speed, lim["speed_limit"]),
                  ("torque_limit", torque, lim["torque_limit"]),
                  ("envelope_limit", self.envelope_ratio(speed, torque), 1.0),
                  ("p_elec_limit", np.abs(traj["p_elec_w"]), lim["p_elec_limit"]))
        return out + [name for name, value, bound in checks
                      if value is not None and near(value, bound)]

    def envelope_ratio(self, speed_rpm: np.ndarray, torque_nm: np.ndarray
                       ) -> np.ndarray | None:
        """|Torque| over the envelope's torque where the envelope, not the torque limit,
        is the bound (above the base speed; a base speed beyond every speed flown never
        binds); None without an envelope."""
        lim = self.drive
        if not lim.has_envelope():
            return None
        env = envelope_torque_nm(lim, speed_rpm)
        below = env < lim.max_torque_nm * (1.0 - ACTIVE_RTOL)
        return np.abs(torque_nm)[below] / env[below]

    def limited_bounds(self) -> dict[str, tuple[float, float]]:
        """The reel speed of the drive's speed limit (within the winch's range)."""
        dt = self.drivetrain
        dl_max = max_reel_speed_m_s(self.drive.max_speed_rpm / dt.gear_ratio, dt.r_winch_m)
        lo, hi = reel_speed_range_m_s(self.system.winch)
        return {"dl_m_s": (max(-dl_max, lo), min(dl_max, hi))}
