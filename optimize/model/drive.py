"""Winch-drive quantities of the kite state (docs/paper_figures.md §1, paper eq. 4).

Drum frame: torque >= 0 when the tether pulls, reel-out (generating) is
negative speed; mechanical power is positive when the drive delivers power to
the drum, so a generating cycle has negative mechanical and electrical power.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from bench.units import RPM_PER_RAD_S


class DriveModel(Protocol):
    """What the OCP needs from a drive power model (``fitting.power_model.PowerModel``)."""

    def casadi_p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> Any:
        """Electrical power drawn from the grid [W] (CasADi expression)."""

    def p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> np.ndarray:
        """Electrical power drawn from the grid [W] (numpy)."""


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


def max_tension_n(max_torque_nm: float, r_winch_m: float) -> float:
    """Tether tension [N] that corresponds to a drum torque limit [N m]."""
    return max_torque_nm / r_winch_m


@dataclass(frozen=True)
class RatedDrive:
    """A drive of the same design as ``base``, rated at another speed, torque and power.

    ``P(n, T) = k_P * P_base(n * n_base / n_rated, T * T_base / T_rated)`` with
    ``k_P = P_rated / P_base``: the base model's efficiency map stretched onto the new
    ratings (similarity scaling). Serves systems whose drive has no bench fit, such as
    the shipped AP2- and MegAWES-size systems in the cold-start benchmark.

    Parameters
    ----------
    base : DriveModel
        A power model with ``nominal_power_w`` and ``sha256`` (``PowerModel``).
    base_speed_rpm, base_torque_nm : float
        Ratings of the base drive [rpm], [N m].
    speed_rpm, torque_nm, nominal_power_w : float
        Ratings of this drive [rpm], [N m], [W].
    """

    base: Any
    base_speed_rpm: float
    base_torque_nm: float
    speed_rpm: float
    torque_nm: float
    nominal_power_w: float

    @property
    def name(self) -> str:
        """Readable name."""
        return (f"{self.base.name} rated at {self.speed_rpm:g} rpm, {self.torque_nm:g} N m, "
                f"{self.nominal_power_w:g} W")

    @property
    def drive(self) -> dict:
        """The ratings, as a power model file's ``drive`` mapping."""
        return {"max_speed_rpm": self.speed_rpm, "max_torque_nm": self.torque_nm,
                "nominal_power_w": self.nominal_power_w}

    @property
    def domain(self) -> None:
        """No measured validity domain: the rating is a similarity assumption."""
        return None

    @property
    def sha256(self) -> str:
        """Hash of the base model and the ratings."""
        text = f"{self.base.sha256}|{self.base_speed_rpm!r}|{self.base_torque_nm!r}|" \
               f"{self.speed_rpm!r}|{self.torque_nm!r}|{self.nominal_power_w!r}"
        return hashlib.sha256(text.encode()).hexdigest()

    def _args(self, speed_rpm: Any, torque_nm: Any) -> tuple[Any, Any, float]:
        return (speed_rpm * (self.base_speed_rpm / self.speed_rpm),
                torque_nm * (self.base_torque_nm / self.torque_nm),
                self.nominal_power_w / self.base.nominal_power_w)

    def casadi_p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> Any:
        """Electrical power drawn from the grid [W] (CasADi expression)."""
        n, t, k = self._args(speed_rpm, torque_nm)
        return k * self.base.casadi_p_elec_w(n, t)

    def p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> np.ndarray:
        """Electrical power drawn from the grid [W] (numpy)."""
        n, t, k = self._args(np.asarray(speed_rpm, float), np.asarray(torque_nm, float))
        return k * np.asarray(self.base.p_elec_w(n, t))
