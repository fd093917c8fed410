"""The drive's torque-speed envelope: the largest torque it gives at a motor speed.

A permanent-magnet machine gives its rated torque up to its base speed; above it the
voltage limit lets the torque fall roughly as ``P / w`` (field weakening). A system
states the envelope by a base speed (constant power ``T_max w_base`` above it: the
rows ``|T w| <= P``, exact and smooth) or by a datasheet table of speed and largest
torque (:class:`EnvelopeTable`). Both apply in both quadrants (motor and generator)
and to the torque at the drive's shaft.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from kernel.drive_envelope import envelope_problem, largest_torque_nm
from kernel.units import RPM_PER_RAD_S

#: the table's kinks are rounded over this fraction of its last speed (the envelope
#: stays below the table, and within ln 2 * this * |slope change| of it)
ROUNDING_FRACTION = 0.005


def constant_power_w(max_torque_nm: float, base_speed_rpm: float) -> float:
    """The power [W] of the constant-power region above the base speed: ``T_max w_base``."""
    return max_torque_nm * base_speed_rpm / RPM_PER_RAD_S


@dataclass(frozen=True)
class EnvelopeTable:
    """A datasheet envelope: largest torque [N m] at motor speeds [rpm], linear between the
    points, flat beyond the last.

    Attributes
    ----------
    speeds_rpm : tuple of float
        Rising from 0.
    torques_nm : tuple of float
        Positive, not rising.
    """

    speeds_rpm: tuple[float, ...]
    torques_nm: tuple[float, ...]

    def __post_init__(self) -> None:
        problem = envelope_problem(None, self.speeds_rpm, self.torques_nm)
        if problem is not None:
            raise ValueError("{}: {} ({} expected)".format(*problem))

    def torque_nm(self, speed_rpm: np.ndarray) -> np.ndarray:
        """The table's largest torque [N m] at ``|speed_rpm|`` (numpy, exact)."""
        return largest_torque_nm(speed_rpm, np.inf, speeds_rpm=self.speeds_rpm,
                                 torques_nm=self.torques_nm)

    def smooth_torque_nm(self, speed_rpm: Any) -> Any:
        """A smooth lower bound of the table's torque (CasADi expression of ``speed_rpm``).

        ``T_0 + sum_k dm_k s(|n| - n_k)`` with the slope changes ``dm_k`` at the table's
        speeds, ``s`` the softplus of width ``w`` (:data:`ROUNDING_FRACTION` of the last
        speed) and ``|n|`` rounded as ``sqrt(n^2 + w^2)``, less ``ln 2 w`` times each
        rising slope change: at or below the table everywhere, within
        ``w (ln 2 sum |dm_k| + max |slope|)`` of it.
        """
        s, t = np.asarray(self.speeds_rpm), np.asarray(self.torques_nm)
        slopes = np.concatenate([np.diff(t) / np.diff(s), [0.0]])
        changes = np.diff(np.concatenate([[0.0], slopes]))
        width = ROUNDING_FRACTION * float(s[-1])
        speed = ca.sqrt(speed_rpm**2 + width**2)  # a smooth |n|
        out = float(t[0]) - math.log(2.0) * width * float(np.sum(np.maximum(changes, 0.0)))
        for speed_k, change in zip(s, changes, strict=True):
            if change != 0:
                out = out + float(change) * width * ca.log1p(ca.exp((speed - speed_k) / width))
        return out

    def smooth_values_nm(self, speed_rpm: np.ndarray) -> np.ndarray:
        """:meth:`smooth_torque_nm` at numbers [N m] (the bound the OCP enforces)."""
        n = ca.SX.sym("n")
        fn = ca.Function("envelope", [n], [self.smooth_torque_nm(n)])
        speeds = np.atleast_1d(np.asarray(speed_rpm, dtype=float))
        return np.asarray(fn.map(speeds.size)(speeds)).ravel().reshape(np.shape(speed_rpm))


def has_envelope(limits: Any) -> bool:
    """Whether the drive states a torque-speed envelope (a base speed or a table)."""
    return limits.base_speed_rpm is not None or limits.envelope_speed_rpm is not None


def envelope_torque_nm(limits: Any, speed_rpm: np.ndarray) -> np.ndarray:
    """The drive's largest torque [N m] at each speed as the OCP bounds it: its
    torque-speed envelope (a table's smooth lower bound), else its torque limit.
    ``limits``: a drive's ``[drive]`` in force (:class:`optimize.system.sections.DriveSection`)
    or the same fields."""
    if limits.base_speed_rpm is not None:
        return largest_torque_nm(speed_rpm, limits.max_torque_nm, limits.base_speed_rpm)
    if limits.envelope_speed_rpm is not None:
        return EnvelopeTable(limits.envelope_speed_rpm, limits.envelope_torque_nm
                             ).smooth_values_nm(speed_rpm)
    return np.full(np.shape(speed_rpm), float(limits.max_torque_nm))


def envelope_curve(limits: Any, points: int = 241) -> tuple[np.ndarray, np.ndarray] | None:
    """The envelope over both quadrants, ``-max_speed_rpm`` to ``max_speed_rpm``: speeds
    [rpm] and largest torques [N m] (the table itself, not its smooth bound); None when
    the drive states none. ``limits`` as :func:`envelope_torque_nm`."""
    if not has_envelope(limits) or limits.max_speed_rpm is None:
        return None
    speed = np.linspace(-limits.max_speed_rpm, limits.max_speed_rpm, points)
    return speed, largest_torque_nm(speed, limits.max_torque_nm, limits.base_speed_rpm,
                                    limits.envelope_speed_rpm, limits.envelope_torque_nm)
