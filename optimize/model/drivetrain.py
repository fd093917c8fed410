"""Winch-drive quantities of the kite state (paper eq. 4), the drivetrain's inertia, the
drive's torque-speed envelope, and the similarity law that carries a drive's power model
to another rating.

Drum frame: torque >= 0 when the tether pulls, reel-out (generating) is
negative speed; mechanical power is positive when the drive delivers power to
the drum, so a generating cycle has negative mechanical and electrical power.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from kernel.drive import Drive
from kernel.units import RPM_PER_RAD_S


def drum_speed_rpm(dl_m_s: Any, r_winch_m: float) -> Any:
    """Drum speed [rpm] from the tether speed [m/s]; reel-out (dl > 0) is negative."""
    return -dl_m_s / r_winch_m * RPM_PER_RAD_S


def drum_torque_nm(tension_n: Any, r_winch_m: float) -> Any:
    """Drum torque [N m] from the tether tension [N]."""
    return tension_n * r_winch_m


def motor_speed_rpm(dl_m_s: Any, r_winch_m: float, gear_ratio: float) -> Any:
    """Motor speed [rpm] from the tether speed [m/s]: drum speed times the gear ratio."""
    return drum_speed_rpm(dl_m_s, r_winch_m) * gear_ratio


def motor_torque_nm(tension_n: Any, r_winch_m: float, gear_ratio: float) -> Any:
    """Motor torque [N m] from the tether tension [N]: drum torque over the gear ratio."""
    return drum_torque_nm(tension_n, r_winch_m) / gear_ratio


def mechanical_power_w(tension_n: Any, dl_m_s: Any) -> Any:
    """Shaft power delivered by the drive [W]: ``-tension * dl`` (negative = generated)."""
    return -tension_n * dl_m_s


def max_reel_speed_m_s(max_speed_rpm: float, r_winch_m: float) -> float:
    """Tether speed [m/s] that corresponds to a drum speed limit [rpm]."""
    return max_speed_rpm / RPM_PER_RAD_S * r_winch_m


def motor_acceleration_rad_s2(ddl_m_s2: Any, r_winch_m: float, gear_ratio: float) -> Any:
    """Motor angular acceleration [rad/s^2] from the tether acceleration [m/s^2]
    (reel-out is negative speed, so ``l'' > 0`` accelerates the motor negatively)."""
    return -gear_ratio * ddl_m_s2 / r_winch_m


@dataclass(frozen=True)
class Drivetrain:
    """The turning parts between the tether and the drive, seen from the motor shaft.

    The drum shaft obeys ``J_d dw_d/dt = T_gear - T_tether`` and the rotor
    ``J_r dw_m/dt = T_drive - T_gear / i`` with ``w_m = i w_d`` (ideal gearbox of ratio
    ``i``), so the torque the drive delivers at its shaft is the tether torque seen at
    the motor plus the acceleration torque of the inertia referred to the motor,
    ``J = J_r + J_d / i^2``: ``T_drive = T_tether / i + J dw_m/dt``. Its power
    ``T_drive w_m`` is the tether's plus ``d/dt (J w_m^2 / 2)``, which integrates to
    zero over a periodic cycle.

    Attributes
    ----------
    r_winch_m : float
        Drum radius [m].
    gear_ratio : float
        Motor speed over drum speed [-].
    drum_inertia_kg_m2 : float
        Inertia turning at drum speed (drum, shaft, gearbox output side) [kg m^2].
    rotor_inertia_kg_m2 : float
        Inertia turning at motor speed (rotor, gearbox input side) [kg m^2].
    """

    r_winch_m: float
    gear_ratio: float
    drum_inertia_kg_m2: float = 0.0
    rotor_inertia_kg_m2: float = 0.0

    @classmethod
    def of(cls, kite: Any) -> Drivetrain:
        """The drivetrain of a kite's parameters (``optimize.model.params.KiteParams``)."""
        return cls(kite.r_winch_m, kite.gear_ratio, kite.drum_inertia_kg_m2,
                   kite.rotor_inertia_kg_m2)

    @property
    def inertia_kg_m2(self) -> float:
        """Inertia referred to the motor shaft, ``J_r + J_d / i^2`` [kg m^2]."""
        return self.rotor_inertia_kg_m2 + self.drum_inertia_kg_m2 / self.gear_ratio**2

    def speed_rpm(self, dl_m_s: Any) -> Any:
        """Motor speed [rpm] from the tether speed [m/s]."""
        return motor_speed_rpm(dl_m_s, self.r_winch_m, self.gear_ratio)

    def tether_torque_nm(self, tension_n: Any) -> Any:
        """The tether's torque seen at the motor shaft [N m]."""
        return motor_torque_nm(tension_n, self.r_winch_m, self.gear_ratio)

    def acceleration_torque_nm(self, ddl_m_s2: Any) -> Any:
        """Torque [N m] that accelerates the inertia: ``J dw_m/dt``."""
        return self.inertia_kg_m2 * motor_acceleration_rad_s2(ddl_m_s2, self.r_winch_m,
                                                              self.gear_ratio)

    def shaft_torque_nm(self, tension_n: Any, ddl_m_s2: Any) -> Any:
        """Torque the drive delivers at its shaft [N m]: tether plus acceleration torque
        (the tether torque alone for a massless drivetrain)."""
        if self.inertia_kg_m2 == 0:
            return self.tether_torque_nm(tension_n)
        return self.tether_torque_nm(tension_n) + self.acceleration_torque_nm(ddl_m_s2)

    def shaft_power_w(self, tension_n: Any, dl_m_s: Any, ddl_m_s2: Any) -> Any:
        """Power the drive delivers at its shaft [W]: the tether's ``-tension dl`` plus the
        rate of change of the kinetic energy ``J w_m dw_m/dt``."""
        if self.inertia_kg_m2 == 0:
            return mechanical_power_w(tension_n, dl_m_s)
        speed_rad_s = -self.gear_ratio * dl_m_s / self.r_winch_m
        return (mechanical_power_w(tension_n, dl_m_s)
                + speed_rad_s * self.acceleration_torque_nm(ddl_m_s2))


#: the similarity law of :func:`carry_power_model`, as recorded in a carried model
SIMILARITY_LAW = ("P_elec(n, T) = P_mech(n, T) + k_n k_T L_base(n / k_n, T / k_T), "
                  "L_base = P_elec_base - P_mech_base: c_ij -> k_n^(1-i) k_T^(1-j) c_ij; "
                  "thermal: every resistance r -> r / (k_n k_T), every capacity c -> "
                  "k_n k_T c, time constants, copper coefficient and temperatures kept")


def carry_power_model(base: Any, speed_ratio: float, torque_ratio: float,
                      drive: Drive | None = None, name: str | None = None,
                      loss_ratio: float = 1.0) -> Any:
    """The power model of a drive of the same design as ``base``, rated ``speed_ratio``
    times its speed and ``torque_ratio`` times its torque (the similarity law).

    With ``k_n = speed_ratio`` and ``k_T = torque_ratio``::

        P_elec(n, T) = P_mech(n, T) + k_n k_T L_base(n / k_n, T / k_T)

    where ``L_base = P_elec_base - P_mech_base`` is the base drive's loss at the
    corresponding operating point ``(n / k_n, T / k_T)``. Because ``P_mech = n T``
    (in consistent units) scales by ``k_n k_T`` too, ``P_elec(n, T) = k_n k_T
    P_elec_base(n / k_n, T / k_T)``: the efficiency at corresponding points is the
    base drive's, the losses stay >= 0 where the base's are, and the sign
    convention is kept (generating: ``|P_elec| < |P_mech|``). For a polynomial
    term ``c n^i T^j`` that is ``c -> k_n^(1-i) k_T^(1-j) c``; the covariance scales
    with the same factors and the validity domain by ``k_n`` in speed and ``k_T``
    in torque. ``k_n = 1`` is the axial (stack-length) scaling of a permanent-magnet
    machine (torque ~ active volume: S. Stipetic, D. Zarko, M. Popescu, "Ultra-fast
    axial and radial scaling of synchronous permanent magnet machines", IET Electric
    Power Applications 10(7), 2016); a speed ratio adds a rewound (or re-geared)
    machine whose losses grow with its power.

    With ``loss_ratio = lam`` other than 1 the losses at corresponding points are ``lam``
    times the law's, ``P_elec = P_mech + lam k_n k_T L_base(n / k_n, T / k_T)``: a drive
    that is more (``lam < 1``) efficient than its base in proportion at every operating
    point (:func:`optimize.system.drive_power_check.rating_loss_ratio` gives ``lam`` of an
    efficiency class). In the polynomial the mechanical term ``(pi / 30) n T`` (rpm) stays
    and every coefficient's loss part scales by ``lam``: ``c_ij -> k_n^(1-i) k_T^(1-j)
    (lam c_ij + (1 - lam) m_ij)`` with ``m`` the mechanical power's coefficients; the
    covariance by ``lam^2`` more.

    A thermal model (``base.thermal``, :meth:`kernel.thermal_model.ThermalModel.carried`)
    is carried so that the
    winding reaches the base drive's temperature at corresponding points: the losses
    grow by ``k_n k_T``, so every thermal resistance falls by it and every heat capacity
    grows by it, node by node (``k_n k_T`` base drives side by side, each with its own
    cooling path and mass); the time constants, the copper coefficient, the reference and ambient
    temperatures are kept. This is how a rating scales with the design (the continuous
    torque ``k_T T_cont`` at the same temperature rise); a larger machine cooled by
    its surface alone (``r_th ~ 1/k^2`` of its length scale ``k``) runs hotter than this.

    Parameters
    ----------
    base : fitting.power_model.PowerModel
    speed_ratio, torque_ratio : float
        ``k_n``, ``k_T`` > 0 [-].
    drive : kernel.drive.Drive, optional
        The carried drive's rating; its ``nominal_power_w`` becomes the model's nominal
        power. Default: the base rating carried (:meth:`kernel.drive.Drive.scaled`).
    name : str, optional
        Model name (default: the base name and the ratios).
    loss_ratio : float, optional
        ``lam`` > 0: the losses at corresponding points over the law's (default 1).

    Returns
    -------
    fitting.power_model.PowerModel

    Raises
    ------
    ValueError
        A ratio not > 0, or ``loss_ratio`` other than 1 for a model without the ``n T``
        term that holds the mechanical power.
    """
    k_n, k_t, lam = float(speed_ratio), float(torque_ratio), float(loss_ratio)
    if not all(math.isfinite(k) and k > 0 for k in (k_n, k_t, lam)):
        raise ValueError(f"speed, torque and loss ratios must be > 0, got {speed_ratio}, "
                         f"{torque_ratio}, {loss_ratio}")
    if drive is None and base.drive is not None:
        drive = base.drive.scaled(k_n, k_t, f"{base.drive.source or ''}; carried x{k_n:g} in "
                                            f"speed, x{k_t:g} in torque")
    nominal = drive.nominal_power_w if drive is not None else base.nominal_power_w * k_n * k_t
    provenance = {"carried_from": {"name": base.name, "model_sha256": base.sha256,
                                   "provenance": base.provenance},
                  "speed_ratio": k_n, "torque_ratio": k_t, "loss_ratio": lam,
                  "law": SIMILARITY_LAW}
    thermal = None if base.thermal is None else base.thermal.carried(lam * k_n * k_t,
                                                                     SIMILARITY_LAW)
    return base.carried(
        k_n, k_t, lam, nominal_power_w=nominal, statistics=None, provenance=provenance,
        drive=drive, name=name or f"{base.name} carried x{k_n:.4g} speed, x{k_t:.4g} torque",
        thermal=thermal)
