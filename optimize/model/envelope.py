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

from kernel.drive import envelope_problem, largest_torque_nm

#: the table's kinks are rounded over this fraction of its last speed (the envelope
#: stays below the table, and within ln 2 * this * |slope change| of it)
ROUNDING_FRACTION = 0.005


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


def envelope_torque_nm(drive: Any, speed_rpm: np.ndarray) -> np.ndarray:
    """The drive's largest torque [N m] at each speed as the OCP bounds it: a table's smooth
    lower bound, else :meth:`kernel.drive.Drive.largest_torque_nm` (its base-speed
    envelope, or its torque limit). ``drive``: a :class:`kernel.drive.Drive`."""
    if drive.envelope_speed_rpm is not None:
        return EnvelopeTable(drive.envelope_speed_rpm, drive.envelope_torque_nm
                             ).smooth_values_nm(speed_rpm)
    return drive.largest_torque_nm(speed_rpm)


def envelope_curve(drive: Any, points: int = 241) -> tuple[np.ndarray, np.ndarray] | None:
    """The envelope over both quadrants, minus to plus the speed limit: speeds [rpm] and
    largest torques [N m] (the table itself, not its smooth bound); None when the drive
    (a :class:`kernel.drive.Drive`) states none."""
    if not drive.has_envelope() or drive.max_speed_rpm is None:
        return None
    speed = np.linspace(-drive.max_speed_rpm, drive.max_speed_rpm, points)
    return speed, drive.largest_torque_nm(speed)
