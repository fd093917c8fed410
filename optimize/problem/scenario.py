"""One optimization scenario: wind speed, objective and whether the drive limits apply."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Objective = Literal["electrical", "mechanical"]


@dataclass(frozen=True)
class Scenario:
    """A pumping-cycle optimization case (paper section V).

    Parameters
    ----------
    wind_speed_m_s : float
        Wind speed at 100 m altitude [m/s] (log shear below and above).
    objective : {"electrical", "mechanical"}
        Maximize the average generated electrical power (through the drive
        model) or the average generated mechanical power.
    drive_limits : bool
        Apply the drive limits (speed, torque, and the RMS and grid-power limits when set).
    """

    wind_speed_m_s: float
    objective: Objective
    drive_limits: bool

    def __post_init__(self) -> None:
        if self.objective not in ("electrical", "mechanical"):
            raise ValueError(
                f"objective must be 'electrical' or 'mechanical', got {self.objective!r}"
            )
        if not self.wind_speed_m_s > 0:
            raise ValueError(f"wind_speed_m_s must be positive, got {self.wind_speed_m_s}")

    @property
    def kind(self) -> str:
        """Objective and limits, e.g. ``"elec-lim"`` or ``"mech-free"``."""
        obj = "elec" if self.objective == "electrical" else "mech"
        return f"{obj}-{'lim' if self.drive_limits else 'free'}"

    @property
    def name(self) -> str:
        """Short label, e.g. ``"elec-lim-7.0"`` or ``"mech-free-8.5"``."""
        return scenario_name(self.kind, self.wind_speed_m_s)


def scenario_name(kind: str, wind_speed_m_s: float) -> str:
    """Name of a scenario, e.g. ``"elec-lim-7.0"`` (kind, then wind speed [m/s])."""
    if round(wind_speed_m_s, 1) == wind_speed_m_s:
        return f"{kind}-{wind_speed_m_s:.1f}"
    return f"{kind}-{wind_speed_m_s:g}"
