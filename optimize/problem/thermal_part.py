"""The winding temperature as a part of the cycle OCP (:mod:`optimize.model.thermal`).

Its states are the thermal network's nodes (the winding first), periodic over the
cycle; its rates the network's under the drive's losses; it puts the copper loss at
the winding temperature into the electrical power; its row is the drive's winding
limit (the ``*-lim`` kinds); its start the cyclic steady temperature of the losses of
the start trajectory (:func:`optimize.model.thermal.periodic_temperatures`, the copper
term at that temperature by a fixed-point iteration); its summary figures the peak
winding temperature and its margin to the limit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from optimize.model.thermal import RANGE_C, SCALE_K, STATE, WindingThermal, periodic_temperatures
from optimize.model.variables import Variables
from optimize.problem.interface import Row
from optimize.problem.part import Part, StartPoint, near

#: fixed-point iterations of the start temperature and the copper losses at it
ITERATIONS = 4


@dataclass(frozen=True)
class ThermalPart(Part):
    """The winding's thermal network (a :class:`optimize.problem.part.Part`).

    Parameters
    ----------
    thermal : WindingThermal
    """

    thermal: WindingThermal
    name: str = "thermal"

    @property
    def states(self) -> Variables:  # type: ignore[override]
        return Variables(self.thermal.states)

    @property
    def periodic(self) -> tuple[str, ...]:  # type: ignore[override]
        return self.thermal.states

    def quantities(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """The electrical power with the copper loss at the winding temperature, and the
        heat [W] into the winding (all the drive's losses)."""
        p_elec = q["p_elec_w"] + self.thermal.copper_drift_w(q["torque_nm"], q[STATE])
        return {"p_elec_w": p_elec, "heat_w": p_elec - q["p_mech_w"]}

    def rates(self, q: Mapping[str, Any]) -> list[Any]:
        """The nodes' ``dtheta/dt`` [K/s]."""
        return self.thermal.rates_k_s([q[s] for s in self.thermal.states], q["heat_w"])

    def rows(self, q: Mapping[str, Any]) -> list[Row]:
        """The winding limit in the ``*-lim`` kinds."""
        return [Row("winding_temperature", q[STATE] / SCALE_K, -np.inf, np.inf,
                    limited=(-np.inf, self.thermal.max_c / SCALE_K))]

    def bounds(self) -> dict[str, tuple[float, float]]:
        """The solver's range only (:data:`optimize.model.thermal.RANGE_C`)."""
        return dict.fromkeys(self.thermal.states, RANGE_C)

    def scales(self) -> dict[str, float]:
        """:data:`optimize.model.thermal.SCALE_K` each."""
        return dict.fromkeys(self.thermal.states, SCALE_K)

    def active_bounds(self, traj: Any, drive_limits: bool) -> list[str]:
        """The winding limit (the ``*-lim`` kinds); the top of the solver's range, beyond
        what the model describes (every kind)."""
        theta = traj[STATE]
        return ([name for name, bound, applies in (
            ("winding_temperature_limit", self.thermal.max_c, drive_limits),
            ("winding_temperature_range", RANGE_C[1], True)) if applies and near(theta, bound)])

    def figures(self, traj: Any) -> dict[str, float]:
        """The winding's highest temperature over the cycle [degC] and the limit's margin
        above it [K] (negative: the cycle would overheat the winding)."""
        peak = float(np.max(np.asarray(traj[STATE], dtype=float)))
        return {"peak_winding_temperature_c": peak, "thermal_margin_k": self.thermal.max_c - peak}

    def guess(self, start: StartPoint) -> dict[str, np.ndarray]:
        """The cyclic steady temperatures of the start's losses, the copper term at the
        winding temperature by :data:`ITERATIONS` fixed-point steps."""
        q, thermal = start.quantities, self.thermal
        heat0 = np.asarray(q["p_elec_w"]) - np.asarray(q["p_mech_w"])
        # the heat at each Radau point, paired with the time of the point before (the
        # last Radau point is the period's end, the start of the next cycle)
        times = np.concatenate([[0.0], start.times_s[:-1]])
        theta = np.full(heat0.size, thermal.steady_c(float(np.mean(heat0))))
        for _ in range(ITERATIONS):
            heat = heat0 + thermal.copper_drift_w(np.asarray(q["torque_nm"]), theta)
            at = periodic_temperatures(times, np.roll(heat, 1), start.period_s, thermal)
            nodes = np.roll(at, -1, axis=1)  # back to the Radau points
            theta = nodes[0]
        return dict(zip(thermal.states, start.on_grid(nodes), strict=True))
