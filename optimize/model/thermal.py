"""The drive's winding temperature in the cycle: a first-order thermal state beside the
kite's, and the copper losses at that temperature.

The fitted one-node model of ``bench fit`` (``power_model.json`` ``thermal``,
docs/schemas.md section 3)::

    tau_th dtheta/dt = theta_amb + r_th q - theta,     q = p_elec - p_mech

with the heat ``q`` [W] the drive's losses at the winding temperature ``theta``
[degC]. The copper loss is the power model's ``T^2`` term; it holds at the mean winding
temperature of the operating points it was fitted on (``theta_points_c``) and scales
with the copper's resistance, ``(1 + a (theta - theta_ref)) / (1 + a (theta_points -
theta_ref))`` (IEC 60034-2-1 resistance correction, ``a`` the fitted coefficient).
The heat is all of the power model's losses: the part the fit takes as an auxiliary
load outside the winding (a fan) heats it here too, which errs on the warm side.

With a periodic boundary condition on ``theta`` the cycle's temperature is its cyclic
steady state: the cycle flown for hours (IEC 60034-1 duty type S6). Because the
time constant (minutes) is long against a cycle (seconds), the temperature ripples
by a fraction of a kelvin about ``theta_amb + r_th mean(q)``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from optimize.model.variables import Variables

#: the thermal state's name (the unit in the name, :mod:`optimize.model.variables`)
STATE = "theta_winding_c"
#: the thermal state's typical magnitude for scaling [K]
SCALE_K = 50.0
#: the thermal state's range [degC]: only keeps the solver in range (the limit of the
#: constrained kinds is the drive's); an optimum on it would overheat the winding beyond
#: what the model describes, reported as the bound ``winding_temperature_range``
RANGE_C = (-100.0, 400.0)
#: the power model's copper-loss term: torque squared (speed power 0, torque power 2)
COPPER_TERM = (0, 2)


@dataclass(frozen=True)
class WindingThermal:
    """The winding's one-node thermal model and its limit.

    Parameters
    ----------
    r_th_k_per_w : float
        Thermal resistance winding to ambient [K/W].
    tau_th_s : float
        Thermal time constant [s].
    ambient_c : float
        Ambient (or coolant) temperature [degC].
    copper_temp_coeff_per_k : float
        Temperature coefficient of the copper's resistance [1/K].
    theta_ref_c : float
        Reference temperature of that coefficient [degC].
    theta_model_c : float
        Winding temperature at which the power model's copper term holds [degC].
    copper_w_per_nm2 : float
        The power model's ``T^2`` coefficient [W/(N m)^2] (0: no copper term).
    max_c : float
        Largest winding temperature [degC], the drive's continuous rating.
    """

    r_th_k_per_w: float
    tau_th_s: float
    ambient_c: float
    copper_temp_coeff_per_k: float
    theta_ref_c: float
    theta_model_c: float
    copper_w_per_nm2: float
    max_c: float

    def __post_init__(self) -> None:
        for name in ("r_th_k_per_w", "tau_th_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not self.max_c > self.ambient_c:
            raise ValueError(f"the winding limit {self.max_c} degC is not above the ambient "
                             f"{self.ambient_c} degC")

    @classmethod
    def of(cls, drive_model: Any, max_c: float, ambient_c: float | None = None
           ) -> WindingThermal:
        """The thermal model of a power model (its ``thermal`` block and ``T^2`` term),
        with the winding limit [degC] and the ambient [degC] (default: the fitted one)."""
        th = drive_model.thermal
        terms = [tuple(t) for t in drive_model.terms]
        copper = (drive_model.coefficients_rpm[terms.index(COPPER_TERM)]
                  if COPPER_TERM in terms else 0.0)
        return cls(r_th_k_per_w=float(th["r_th_k_per_w"]), tau_th_s=float(th["tau_th_s"]),
                   ambient_c=float(th["ambient_c"] if ambient_c is None else ambient_c),
                   copper_temp_coeff_per_k=float(th["copper_temp_coeff_per_k"]),
                   theta_ref_c=float(th["theta_ref_c"]),
                   theta_model_c=float(th.get("theta_points_c", th["theta_ref_c"])),
                   copper_w_per_nm2=float(copper), max_c=float(max_c))

    def copper_drift_w(self, torque_nm: Any, theta_c: Any) -> Any:
        """Change of the copper loss [W] from the power model's temperature to ``theta_c``."""
        a = self.copper_temp_coeff_per_k
        factor = ((1 + a * (theta_c - self.theta_ref_c))
                  / (1 + a * (self.theta_model_c - self.theta_ref_c)))
        return self.copper_w_per_nm2 * torque_nm**2 * (factor - 1)

    def rate_k_s(self, theta_c: Any, heat_w: Any) -> Any:
        """``dtheta/dt`` [K/s] at the temperature ``theta_c`` and the heat ``heat_w``."""
        return (self.ambient_c + self.r_th_k_per_w * heat_w - theta_c) / self.tau_th_s

    def steady_c(self, heat_w: float) -> float:
        """Steady temperature [degC] under a constant heat [W]."""
        return self.ambient_c + self.r_th_k_per_w * heat_w


def with_winding_temperature(base: Any, heat_w: ca.Function, thermal: WindingThermal) -> Any:
    """The model ``base`` (a :class:`optimize.model.kite_model.KiteDae`) with the winding
    temperature appended to its state, periodic over the cycle.

    Parameters
    ----------
    base : KiteDae
    heat_w : casadi.Function
        ``(x, z, theta_c) -> heat [W]`` on ``base``'s state and algebraic variables.
    thermal : WindingThermal
    """
    n = base.states.size
    x = ca.SX.sym("x", n + 1)
    u = ca.SX.sym("u", base.controls.size)
    z = ca.SX.sym("z", base.algebraic.size)
    w = ca.SX.sym("wind_ref_m_s")
    fict = ca.SX.sym("fict", base.fictitious.size)
    xb, theta = x[:n], x[n]
    z_phys = base.solve_z(xb, u, w)
    outputs = base.outputs(xb, u, z, w)
    return dataclasses.replace(
        base,
        states=Variables((*base.states.names, STATE)),
        periodic=(*base.periodic, STATE),
        ode=ca.Function("ode", [x, u, z], [ca.vertcat(
            base.ode(xb, u, z), thermal.rate_k_s(theta, heat_w(xb, z, theta)))],
            ["x", "u", "z"], ["xdot"]),
        alg=ca.Function("alg", [x, u, z, w, fict], [base.alg(xb, u, z, w, fict)]),
        outputs=ca.Function("outputs", [x, u, z, w], list(outputs),
                            ["x", "u", "z", "wind"], base.outputs.name_out()),
        invariants=ca.Function("invariants", [x], list(base.invariants(xb))),
        explicit_ode=ca.Function("explicit_ode", [x, u, w], [ca.vertcat(
            base.explicit_ode(xb, u, w),
            thermal.rate_k_s(theta, heat_w(xb, z_phys, theta)))]),
        solve_z=ca.Function("solve_z", [x, u, w], [z_phys]),
    )


def periodic_temperature(times_s: np.ndarray, heat_w: np.ndarray, period_s: float,
                         thermal: WindingThermal, substeps: int = 20) -> np.ndarray:
    """The cyclic steady temperature [degC] at ``times_s`` of a heat profile over a cycle.

    The heat [W] is linear between the given points (``times_s`` rising from 0, within
    the period) and periodic; the ODE is integrated exactly for the heat held at its
    mid value over each of ``substeps`` sub-steps per segment, and the start
    temperature solves ``theta(T) = theta(0)`` (the map over one cycle is affine).
    """
    t = np.append(np.asarray(times_s, float), period_s)
    q = np.append(np.asarray(heat_w, float), heat_w[0])
    gains = np.zeros(len(t))  # theta(t_k) - exp(-t_k / tau) theta(0)
    for k in range(len(t) - 1):
        e = math.exp(-(t[k + 1] - t[k]) / substeps / thermal.tau_th_s)
        g = gains[k]
        for s in range(substeps):
            g = g * e + (1 - e) * thermal.steady_c(q[k] + (q[k + 1] - q[k]) * (s + 0.5)
                                                   / substeps)
        gains[k + 1] = g
    decay = np.exp(-(t - t[0]) / thermal.tau_th_s)
    theta0 = gains[-1] / (1 - decay[-1])
    return (decay * theta0 + gains)[:-1]
