"""A drive's torque-speed envelope as a rating states it: the keys, their checks, and
the largest torque at a speed.

A permanent-magnet machine gives its rated torque up to its base speed; above it the
voltage limit lets the torque fall roughly as ``P / w`` (field weakening). A rating
states it one of two ways (a campaign's ``drive.toml``, docs/schemas.md section 1; a
system file's ``[drive]``, docs/system_file.md), at the shaft the power model is
written for, in both quadrants:

    base_speed_rpm = 1000.0                  # constant power T_max w_base above it
    envelope_speed_rpm = [0, 1000, 1500]     # or a datasheet table: speeds rising from 0
    envelope_torque_nm = [78, 78, 52]        # and the largest torques, not rising

The OCP's smooth form of it is :mod:`optimize.model.envelope`.
"""

from __future__ import annotations

import numpy as np

#: the envelope's keys (each optional; a base speed or a table, not both)
ENVELOPE_KEYS = ("base_speed_rpm", "envelope_speed_rpm", "envelope_torque_nm")


def envelope_problem(base_speed_rpm: float | None, speeds_rpm, torques_nm
                     ) -> tuple[str, str, str] | None:
    """What is wrong with an envelope's keys, or None.

    Returns
    -------
    tuple of str or None
        ``(key, what is wrong, what was expected)``.
    """
    if base_speed_rpm is not None and not base_speed_rpm > 0:
        return "base_speed_rpm", f"{base_speed_rpm!r}", "a base speed > 0 rpm"
    if speeds_rpm is None:
        if torques_nm is not None:
            return ("envelope_speed_rpm", "missing", "envelope_speed_rpm with "
                    "envelope_torque_nm (a table of speed and largest torque)")
        return None
    if torques_nm is None:
        return ("envelope_torque_nm", "missing", "envelope_torque_nm with "
                "envelope_speed_rpm (a table of speed and largest torque)")
    if base_speed_rpm is not None:
        return ("base_speed_rpm", "given with an envelope table",
                "either base_speed_rpm or envelope_speed_rpm/envelope_torque_nm")
    speeds, torques = list(speeds_rpm), list(torques_nm)
    if len(speeds) != len(torques):
        return ("envelope_torque_nm", f"{len(torques)} torques for {len(speeds)} speeds",
                "one torque per speed")
    if len(speeds) < 2 or speeds[0] != 0 or any(b <= a for a, b in zip(speeds, speeds[1:],
                                                                        strict=False)):
        return ("envelope_speed_rpm", f"{speeds} is not monotone from 0",
                "speeds rising strictly from 0 rpm (at least two)")
    if min(torques) <= 0 or any(b > a for a, b in zip(torques, torques[1:], strict=False)):
        return ("envelope_torque_nm", f"{torques} is not monotone",
                "positive torques that do not rise with speed")
    return None


def largest_torque_nm(speed_rpm, max_torque_nm: float, base_speed_rpm: float | None = None,
                      speeds_rpm=None, torques_nm=None) -> np.ndarray:
    """The largest torque [N m] a drive gives at ``speed_rpm`` (either sign): its
    envelope (a table linear between its points and flat beyond the last) capped by
    its torque limit; the torque limit alone when it states no envelope."""
    speed = np.abs(np.asarray(speed_rpm, dtype=float))
    if base_speed_rpm is not None:
        return np.minimum(max_torque_nm, max_torque_nm * base_speed_rpm
                          / np.maximum(speed, 1e-12))
    if speeds_rpm is not None:
        return np.minimum(np.interp(speed, speeds_rpm, torques_nm), max_torque_nm)
    return np.full(speed.shape, float(max_torque_nm))
