"""Torque-flange zero offset from the tare an operator logs at the start of a session.

Before the first setpoint the drive stands still without load for a few seconds,
so the torque the flange reads there is its zero offset. :class:`TareFinder` is
fed the DAQ stream in order (drum frame) and keeps the samples of the leading
standstill: from the first sample until |speed| first reaches the standstill
limit. The offset is the median torque of those samples (robust to isolated
bad samples), leaving out the last :data:`GUARD_S` before the drive starts
(the load may already be rising). No tare is found, and nothing is corrected,
when the session does not start at standstill, the standstill is shorter than
:data:`MIN_TARE_S`, or its torque is too large to be a zero offset (a load).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: standstill: |drum speed| below this fraction of the speed sensor's range [-] ...
STANDSTILL_FRAC = 0.002
#: ... and at least this [rpm]
STANDSTILL_MIN_RPM = 1.0
#: samples this close to the start of motion are left out [s]
GUARD_S = 0.5
#: shortest usable tare (after the guard) [s]
MIN_TARE_S = 1.0
#: a standstill torque above this fraction of the torque range is a load, not an offset [-]
MAX_OFFSET_FRAC = 0.02
#: samples kept at most (a session standing still for hours needs no more) [-]
MAX_SAMPLES = 200_000


@dataclass(frozen=True)
class Tare:
    """A found tare segment and the zero offset it gives.

    Parameters
    ----------
    offset_nm : float
        Median drum-frame torque at standstill, to subtract from every sample [N m].
    t_start_s, t_end_s : float
        First and last sample used, DAQ clock [s].
    t_motion_s : float
        First sample at or above the standstill limit, DAQ clock [s]; no steady
        window may start before it.
    n_samples : int
        Samples the median is taken over.
    speed_limit_rpm : float
        The standstill limit used [rpm].
    """

    offset_nm: float
    t_start_s: float
    t_end_s: float
    t_motion_s: float
    n_samples: int
    speed_limit_rpm: float

    def manifest(self) -> dict:
        """The manifest's ``torque_zero_tare`` entry."""
        return {"t_start_s": round(self.t_start_s, 6), "t_end_s": round(self.t_end_s, 6),
                "n_samples": self.n_samples, "speed_limit_rpm": self.speed_limit_rpm}


class TareFinder:
    """Collect the leading standstill of a DAQ stream and estimate the flange zero offset.

    Parameters
    ----------
    speed_range_rpm : float
        Speed sensor range seen from the drum [rpm] (sets the standstill limit).
    torque_range_nm : float
        Torque sensor range seen from the drum [N m] (bounds a plausible offset).
    """

    def __init__(self, speed_range_rpm: float, torque_range_nm: float) -> None:
        self.limit_rpm = max(STANDSTILL_FRAC * speed_range_rpm, STANDSTILL_MIN_RPM)
        self.max_offset_nm = MAX_OFFSET_FRAC * torque_range_nm
        self._t: list[np.ndarray] = []
        self._torque: list[np.ndarray] = []
        self._kept = 0
        self.t_motion_s: float | None = None

    def feed(self, t: np.ndarray, speed_rpm: np.ndarray, torque_nm: np.ndarray) -> None:
        """Add the next chunk (time-sorted, drum frame); cheap once motion has started."""
        if self.t_motion_s is not None or t.size == 0:
            return
        moving = np.flatnonzero(np.abs(speed_rpm) >= self.limit_rpm)  # NaN: not moving
        end = int(moving[0]) if moving.size else t.size
        if moving.size:
            self.t_motion_s = float(t[end])
        ok = np.isfinite(speed_rpm[:end]) & np.isfinite(torque_nm[:end])
        room = MAX_SAMPLES - self._kept
        if room > 0:
            self._t.append(t[:end][ok][:room])
            self._torque.append(torque_nm[:end][ok][:room])
            self._kept += self._t[-1].size

    def result(self) -> tuple[Tare | None, str]:
        """The tare, or ``None`` and why there is none."""
        if self.t_motion_s is None:
            return None, "the drive never leaves standstill"
        t = np.concatenate(self._t) if self._t else np.zeros(0)
        torque = np.concatenate(self._torque) if self._torque else np.zeros(0)
        use = t <= self.t_motion_s - GUARD_S
        t, torque = t[use], torque[use]
        if t.size < 2 or t[-1] - t[0] < MIN_TARE_S:
            return None, (f"no standstill of at least {MIN_TARE_S + GUARD_S:g} s "
                          f"(|speed| < {self.limit_rpm:g} rpm) before the first motion")
        offset = float(np.median(torque))
        if abs(offset) > self.max_offset_nm:
            return None, (f"torque at the leading standstill is {offset:.3g} N m, more than "
                          f"{MAX_OFFSET_FRAC:.0%} of the range: a load, not a zero offset")
        return Tare(offset_nm=offset, t_start_s=float(t[0]), t_end_s=float(t[-1]),
                    t_motion_s=self.t_motion_s, n_samples=int(t.size),
                    speed_limit_rpm=self.limit_rpm), ""
