"""Winch-drive quantities of the kite state (REFERENCE.md §1, paper eq. 4).

Drum frame: torque >= 0 when the tether pulls, reel-out (generating) is
negative speed; mechanical power is positive when the drive delivers power to
the drum, so a generating cycle has negative mechanical and electrical power.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

#: conversion of rad/s to rpm
RPM_PER_RAD_S = 60.0 / (2.0 * np.pi)


class DriveModel(Protocol):
    """What the OCP needs from a drive power model (``fitting.model_file.PowerModel``)."""

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


def mechanical_power_w(tension_n: Any, dl_m_s: Any) -> Any:
    """Shaft power delivered by the drive [W]: ``-tension * dl`` (negative = generated)."""
    return -tension_n * dl_m_s


def max_reel_speed_m_s(max_speed_rpm: float, r_winch_m: float) -> float:
    """Tether speed [m/s] that corresponds to a drum speed limit [rpm]."""
    return max_speed_rpm / RPM_PER_RAD_S * r_winch_m


def max_tension_n(max_torque_nm: float, r_winch_m: float) -> float:
    """Tether tension [N] that corresponds to a drum torque limit [N m]."""
    return max_torque_nm / r_winch_m
