"""One optimization scenario: wind speed and the kind (objective, drive limits)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from kernel.names import WIND_SPEED
from optimize.kinds import KINDS, Kind, kind_of

#: the name of an objective (:class:`optimize.kinds.Objective` is the objective itself)
ObjectiveName = Literal["electrical", "mechanical"]


@dataclass(frozen=True)
class Scenario:
    """A pumping-cycle optimization case (paper section V).

    Parameters
    ----------
    wind_speed_m_s : float
        Wind speed at 100 m altitude [m/s] (log shear below and above).
    objective : {"electrical", "mechanical"}
        Maximize the average generated electrical power (through the drive
        model) or the average generated mechanical power
        (:data:`optimize.kinds.OBJECTIVES`).
    drive_limits : bool
        Apply the drive limits (speed, torque, and the RMS and grid-power limits when set).
    """

    wind_speed_m_s: float
    objective: ObjectiveName
    drive_limits: bool

    def __post_init__(self) -> None:
        kind_of(self.objective, self.drive_limits)  # raises on an unknown objective
        if not self.wind_speed_m_s > 0:
            raise ValueError(f"wind_speed_m_s must be positive, got {self.wind_speed_m_s}")
        object.__setattr__(self, "wind_speed_m_s", float(self.wind_speed_m_s))

    @classmethod
    def of_kind(cls, kind: str | Kind, wind_speed_m_s: float) -> Scenario:
        """The scenario of a kind (key or :class:`optimize.kinds.Kind`) at a wind speed."""
        k = KINDS[kind] if isinstance(kind, str) else kind
        return cls(wind_speed_m_s, k.objective, k.drive_limits)

    def at(self, wind_speed_m_s: float) -> Scenario:
        """The scenario of the same kind at another wind speed [m/s]."""
        return Scenario(wind_speed_m_s, self.objective, self.drive_limits)

    @property
    def kind_spec(self) -> Kind:
        """The scenario's kind: its objective weights, summary column and label."""
        return kind_of(self.objective, self.drive_limits)

    @property
    def kind(self) -> str:
        """Objective and limits, e.g. ``"elec-lim"`` or ``"mech-free"``."""
        return self.kind_spec.key

    @property
    def weights(self) -> dict[str, float]:
        """Objective weights by cycle-average name (:attr:`optimize.kinds.Kind.weights`)."""
        return self.kind_spec.weights

    @property
    def parameters(self) -> dict[str, float]:
        """The model's parameters of the scenario by name: the wind speed at the
        reference height (:data:`kernel.names.WIND_SPEED`) [m/s]."""
        return {WIND_SPEED: self.wind_speed_m_s}

    @property
    def name(self) -> str:
        """Short label, e.g. ``"elec-lim-7.0"`` or ``"mech-free-8.5"``."""
        return scenario_name(self.kind, self.wind_speed_m_s)


def scenario_name(kind: str, wind_speed_m_s: float) -> str:
    """Name of a scenario, e.g. ``"elec-lim-7.0"`` (kind, then wind speed [m/s])."""
    if round(wind_speed_m_s, 1) == wind_speed_m_s:
        return f"{kind}-{wind_speed_m_s:.1f}"
    return f"{kind}-{wind_speed_m_s:g}"
