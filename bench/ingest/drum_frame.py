"""The drum frame: logged speed and torque to the drum shaft (signs, gear, a signed
torque folded), and the check that operating points have drum torque >= 0."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bench.ingest.session import Session
from kernel.errors import InputError


def to_drum_frame(session: Session, speed, torque):
    """Logged speed and torque to the drum shaft (signs, gear); a signed torque is folded
    later (:func:`fold_signed`), after the zero offset is off."""
    speed = speed * session.speed_sign
    torque = torque * session.torque_sign
    if session.measured_side == "motor":
        speed = speed / session.gear_ratio
        torque = torque * session.gear_ratio
    return speed, torque


def drum_ranges(session: Session) -> dict[str, float]:
    """Sensor ranges [rpm, N m, W] seen from the drum (ranges are of the measured shaft)."""
    r = dict(session.ranges)
    if session.measured_side == "motor":
        r["speed"] /= session.gear_ratio
        r["torque"] *= session.gear_ratio
    return r


def fold_signed(speed_rpm: np.ndarray, torque_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed torque into the drum frame: where torque < 0, flip speed and torque.

    A bench that logs generator mode as speed > 0, torque < 0 then gives
    torque >= 0 and reel-out (generating) as negative speed; p_mech is unchanged.
    """
    neg = torque_nm < 0
    return np.where(neg, -speed_rpm, speed_rpm), np.where(neg, -torque_nm, torque_nm)


def check_drum_torque(session: Session, torque_nm: np.ndarray, tol_nm: float,
                      where: Path) -> None:
    """Raise when operating points have negative drum torque (against the drum frame).

    A point counts when its mean torque is below ``-tol_nm`` (the steady tolerance,
    so a no-load point at 0 +- noise passes).
    """
    neg = np.flatnonzero(np.asarray(torque_nm) < -tol_nm)
    if neg.size:
        raise InputError(
            where, f"{neg.size} of {len(torque_nm)} operating points have negative drum torque "
            f"(down to {float(np.min(torque_nm)):.4g} N m)", column="torque",
            expected="torque >= 0 in the drum frame: torque_sign = \"signed\" in "
            f"{session.path.name} when the bench logs generator mode as torque < 0 (speed and "
            "torque are then flipped where torque < 0), or torque_sign = -1 when every torque "
            "is logged with the opposite sign",
        )
