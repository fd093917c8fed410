"""The drive's winding temperature in the cycle: a thermal network beside the kite's
state, and the copper losses at that temperature.

The fitted network of ``bench fit`` (``power_model.json`` ``thermal``, docs/schemas.md
section 3) as a ladder of nodes from the winding outwards (one node, or the winding
and the housing), each node ``k`` with its heat capacity ``c_k`` and the resistance
``r_k`` to the next node (the last: to the ambient)::

    tau_k dtheta_k/dt = theta_(k+1) + r_k q_k - theta_k,    tau_k = r_k c_k

with ``q_0 = q`` the heat [W], the drive's losses at the winding temperature
``theta_0`` [degC], ``q_k = (theta_(k-1) - theta_k) / r_(k-1)`` the heat from the node
before, and ``theta_n`` the ambient. One node is ``tau_th dtheta/dt = theta_amb + r_th q
- theta``. The copper loss is the power model's ``T^2`` term; it holds at the mean
winding temperature of the operating points it was fitted on (``theta_points_c``) and
scales with the copper's resistance, ``(1 + a (theta - theta_ref)) / (1 + a (theta_points
- theta_ref))`` (IEC 60034-2-1 resistance correction, ``a`` the fitted coefficient).
The heat is all of the power model's losses: the part the fit takes as an auxiliary
load outside the winding (a fan) heats it here too, which errs on the warm side.

With periodic boundary conditions on the nodes the cycle's temperature is its cyclic
steady state: the cycle flown for hours (IEC 60034-1 duty type S6). Because the
time constants (minutes) are long against a cycle (seconds), the winding ripples
by a fraction of a kelvin about ``theta_amb + r_th mean(q)``, ``r_th = sum r_k``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import expm

from kernel.drive import DriveModel

#: the winding temperature's state (the unit in the name, :mod:`optimize.model.variables`)
STATE = "theta_winding_c"
#: the states of a ladder's nodes from the winding outwards (beyond them ``theta_node_<k>_c``)
NODE_STATES = (STATE, "theta_housing_c")
#: the thermal state's typical magnitude for scaling [K]
SCALE_K = 50.0
#: the thermal state's range [degC]: only keeps the solver in range (the limit of the
#: constrained kinds is the drive's); an optimum on it would overheat the winding beyond
#: what the model describes, reported as the bound ``winding_temperature_range``
RANGE_C = (-100.0, 400.0)


def node_states(n: int) -> tuple[str, ...]:
    """The state names of an ``n``-node ladder, from the winding outwards."""
    return tuple(NODE_STATES[k] if k < len(NODE_STATES) else f"theta_node_{k + 1}_c"
                 for k in range(n))


@dataclass(frozen=True)
class WindingThermal:
    """The winding's thermal network and its limit.

    Parameters
    ----------
    ladder : tuple of (float, float)
        Per node from the winding: the resistance to the next node (the last: to the
        ambient) [K/W] and its time constant ``r_k c_k`` [s].
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

    ladder: tuple[tuple[float, float], ...]
    ambient_c: float
    copper_temp_coeff_per_k: float
    theta_ref_c: float
    theta_model_c: float
    copper_w_per_nm2: float
    max_c: float

    def __post_init__(self) -> None:
        if not self.ladder or not all(r > 0 and tau > 0 for r, tau in self.ladder):
            raise ValueError(f"every node needs a resistance and time constant > 0, got "
                             f"{self.ladder}")
        if not self.max_c > self.ambient_c:
            raise ValueError(f"the winding limit {self.max_c} degC is not above the ambient "
                             f"{self.ambient_c} degC")

    @classmethod
    def of(cls, drive_model: DriveModel, max_c: float, ambient_c: float | None = None
           ) -> WindingThermal:
        """The thermal model of a power model (its ``thermal``, a
        :class:`kernel.thermal_model.ThermalModel`, and its copper loss), with the winding
        limit [degC] and the ambient [degC] (default: the fitted one)."""
        th = drive_model.thermal
        return cls(ladder=th.network(),
                   ambient_c=float(th.ambient_c if ambient_c is None else ambient_c),
                   copper_temp_coeff_per_k=float(th.copper_temp_coeff_per_k),
                   theta_ref_c=float(th.theta_ref_c),
                   theta_model_c=float(th.theta_ref_c if th.theta_points_c is None
                                       else th.theta_points_c),
                   copper_w_per_nm2=float(drive_model.copper_w_per_nm2), max_c=float(max_c))

    @property
    def states(self) -> tuple[str, ...]:
        """The nodes' state names, the winding first."""
        return node_states(len(self.ladder))

    @property
    def r_th_k_per_w(self) -> float:
        """Steady resistance winding to ambient [K/W]."""
        return float(sum(r for r, _ in self.ladder))

    @property
    def tau_th_s(self) -> float:
        """The winding's time constant [s]; with more nodes, its step response's mean
        time constant (``-Z'(0) / Z(0)`` of the network's impedance)."""
        if len(self.ladder) == 1:
            return self.ladder[0][1]
        a, b = self.matrices()
        return float(np.linalg.solve(a, np.linalg.solve(a, b))[0] / self.r_th_k_per_w)

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``A``, ``b`` of the nodes' rises over the ambient, ``dx/dt = A x + b q``."""
        n = len(self.ladder)
        a, b = np.zeros((n, n)), np.zeros(n)
        for k, (r, tau) in enumerate(self.ladder):
            a[k, k] -= 1.0 / tau
            if k + 1 < n:
                a[k, k + 1] += 1.0 / tau
            if k > 0:  # the heat from the node before, r_k (theta_(k-1) - theta_k) / r_(k-1)
                g = r / self.ladder[k - 1][0] / tau
                a[k, k - 1] += g
                a[k, k] -= g
        b[0] = self.ladder[0][0] / self.ladder[0][1]
        return a, b

    def copper_drift_w(self, torque_nm: Any, theta_c: Any) -> Any:
        """Change of the copper loss [W] from the power model's temperature to ``theta_c``."""
        a = self.copper_temp_coeff_per_k
        factor = ((1 + a * (theta_c - self.theta_ref_c))
                  / (1 + a * (self.theta_model_c - self.theta_ref_c)))
        return self.copper_w_per_nm2 * torque_nm**2 * (factor - 1)

    def rates_k_s(self, theta_c: list, heat_w: Any) -> list:
        """``dtheta_k/dt`` [K/s] of the nodes at ``theta_c`` (one per node) and the heat
        ``heat_w`` [W] into the winding."""
        n, out = len(self.ladder), []
        for k, (r, tau) in enumerate(self.ladder):
            after = theta_c[k + 1] if k + 1 < n else self.ambient_c
            inflow = heat_w if k == 0 else (theta_c[k - 1] - theta_c[k]) / self.ladder[k - 1][0]
            out.append((after + r * inflow - theta_c[k]) / tau)
        return out

    def steady_c(self, heat_w: float) -> float:
        """Steady winding temperature [degC] under a constant heat [W]."""
        return self.ambient_c + self.r_th_k_per_w * heat_w


def periodic_temperatures(times_s: np.ndarray, heat_w: np.ndarray, period_s: float,
                          thermal: WindingThermal, substeps: int = 20) -> np.ndarray:
    """The cyclic steady temperatures [degC] of the nodes at ``times_s`` under a heat
    profile over a cycle, ``(nodes, len(times_s))``, the winding first.

    The heat [W] is linear between the given points (``times_s`` rising from 0, within
    the period) and periodic; the ODE is integrated exactly for the heat held at its
    mid value over each of ``substeps`` sub-steps per segment, and the start
    temperatures solve ``theta(T) = theta(0)`` (the map over one cycle is affine).
    """
    t = np.append(np.asarray(times_s, float), period_s)
    q = np.append(np.asarray(heat_w, float), heat_w[0])
    a, b = thermal.matrices()
    m = len(thermal.ladder)
    gains = np.zeros((len(t), m))  # rise(t_k) - Phi(t_k) rise(0)
    phis = [np.eye(m)]
    for k in range(len(t) - 1):
        e = expm(a * (t[k + 1] - t[k]) / substeps)
        step = np.linalg.solve(a, (e - np.eye(m)) @ b)
        g = gains[k]
        for s in range(substeps):
            g = e @ g + step * (q[k] + (q[k + 1] - q[k]) * (s + 0.5) / substeps)
        gains[k + 1] = g
        phis.append(np.linalg.matrix_power(e, substeps) @ phis[-1])
    rise0 = np.linalg.solve(np.eye(m) - phis[-1], gains[-1])
    rises = np.array([phi @ rise0 for phi in phis]) + gains
    return (thermal.ambient_c + rises[:-1]).T
