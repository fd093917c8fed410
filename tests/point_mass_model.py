"""A second model for the OCP's model interface: a point mass on a rigid tether.

A pendulum in the vertical x-z plane (z down), written like the kite: position and
velocity states, the tether multiplier ``nu`` as an algebraic variable with the
constraint's second derivative as a residual row, the invariants at the start and
periodicity of the components that fix the phase-space point. A horizontal force is
the control; the objective is its regularization, so the optimal periodic motion is
the free oscillation, whose period has a closed form (complete elliptic integral).
Only :mod:`optimize.problem.interface`, :mod:`optimize.model` and CasADi are used:
nothing of the kite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from scipy.special import ellipk

from optimize.model.variables import Variables
from optimize.problem.interface import Point, Row, weight_param

STATES = Variables(("r_x_m", "r_z_m", "v_x_m_s", "v_z_m_s"))
CONTROLS = Variables(("f_x_n",))
ALGEBRAIC = Variables(("a_x_m_s2", "a_z_m_s2", "nu_n_per_m"))
FICTITIOUS = Variables(("f_fict_x_n", "f_fict_z_n"))


@dataclass(frozen=True)
class Pendulum:
    """Mass [kg], tether length [m], gravity [m/s^2] and release angle [deg]."""

    mass_kg: float = 2.0
    length_m: float = 1.5
    g_m_s2: float = 9.81
    release_deg: float = 60.0

    def period_s(self) -> float:
        """Exact period of the free oscillation: ``4 sqrt(L/g) K(sin^2(theta0/2))``."""
        m = math.sin(math.radians(self.release_deg) / 2) ** 2
        return 4.0 * math.sqrt(self.length_m / self.g_m_s2) * float(ellipk(m))


@dataclass(frozen=True)
class PendulumDae:
    """The pendulum as a :class:`optimize.model.dae.Dae`."""

    ode: ca.Function
    alg: ca.Function
    states: Variables = STATES
    controls: Variables = CONTROLS
    algebraic: Variables = ALGEBRAIC
    fictitious: Variables = FICTITIOUS
    parameters: Variables = Variables(())
    periodic: tuple[str, ...] = ("r_x_m", "v_x_m_s")


def pendulum_dae(p: Pendulum) -> PendulumDae:
    """``rdot = v, vdot = a``; ``m a = -nu r + m g e_z + f e_x (+ fict)``, ``d2c/dt2 = 0``."""
    x, u = ca.SX.sym("x", STATES.size), ca.SX.sym("u", CONTROLS.size)
    z, fict = ca.SX.sym("z", ALGEBRAIC.size), ca.SX.sym("fict", FICTITIOUS.size)
    par = ca.SX.sym("p", 0)  # the model's parameters: the pendulum has none
    r, v, a, nu = x[0:2], x[2:4], z[0:2], z[2]
    force = ca.vertcat(u[0], p.mass_kg * p.g_m_s2) - nu * r + fict
    residual = ca.vertcat(p.mass_kg * a - force, ca.dot(v, v) + ca.dot(r, a))
    return PendulumDae(
        ode=ca.Function("pendulum_ode", [x, u, z], [ca.vertcat(v, a)]),
        alg=ca.Function("pendulum_alg", [x, u, z, par, fict], [residual]),
    )


@dataclass(frozen=True)
class PendulumScales:
    state: np.ndarray
    control: np.ndarray
    algebraic: np.ndarray
    fictitious: np.ndarray
    period_s: float


@dataclass(frozen=True)
class PendulumFormulation:
    """The pendulum's cycle OCP (a :class:`optimize.problem.interface.CycleFormulation`)."""

    pendulum: Pendulum
    dae: PendulumDae
    scales: PendulumScales
    parameters: tuple[str, ...] = ()
    averages: tuple[str, ...] = ("p_ctrl_w",)
    objective_averages: tuple[str, ...] = ("p_ctrl_w",)
    constrained_averages: tuple[str, ...] = field(default=())
    objective_scale: float = 1.0

    def ode(self, x: Any, u: Any, z: Any) -> Any:
        return self.dae.ode(x, u, z)

    def point(self, x: Any, u: Any, z: Any, fict: Any, params: Any) -> Point:
        residual = self.dae.alg(x, u, z, params, fict) / self.pendulum.mass_kg
        return Point(rows=[Row("algebraic", residual / self.pendulum.g_m_s2)],
                     averages={"p_ctrl_w": u[0] * x[2]},
                     fict_sq=ca.sumsqr(fict / ca.DM(self.scales.fictitious)))

    def trajectory_outputs(self, x, u, z, params) -> dict:
        return {"tension_n": np.hypot(x[0], x[1]) * z[2]}

    def control_cost(self, u: Any) -> Any:
        return ca.sumsqr(u / (self.pendulum.mass_kg * self.pendulum.g_m_s2))

    def start_rows(self, x0: Any) -> list[Row]:
        r, v, length = x0[0:2], x0[2:4], self.pendulum.length_m
        return [Row("invariant_c", (ca.dot(r, r) - length**2) / (2 * length**2)),
                Row("invariant_cdot", ca.dot(r, v) / length**2)]

    def periodicity_rows(self, x0: Any, x_end: Any) -> list[Row]:
        per = self.dae.states.indices(self.dae.periodic)
        return [Row("periodic", (x_end[per] - x0[per]) / ca.DM(self.scales.state[per]))]

    def average_rows(self, averages: dict) -> list[Row]:
        return []

    def objective(self, weights, averages, regularization, tracking, fict_penalty) -> Any:
        return (weights[weight_param("p_ctrl_w")] * averages["p_ctrl_w"] / self.objective_scale
                + weights["w_reg"] * regularization + weights["w_track"] * tracking
                + weights["w_fict"] * fict_penalty)

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        reach = 2.0 * self.pendulum.length_m
        return (np.array([-reach, 0.05 * self.pendulum.length_m, -20.0, -20.0]),
                np.array([reach, reach, 20.0, 20.0]))

    def start_state_fixed(self) -> dict[int, float]:
        release = math.radians(self.pendulum.release_deg)
        return {STATES.index("r_x_m"): self.pendulum.length_m * math.sin(release),
                STATES.index("v_x_m_s"): 0.0}

    def limited_state_bounds(self) -> dict:
        return {}

    def algebraic_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.full(ALGEBRAIC.size, -np.inf), np.full(ALGEBRAIC.size, np.inf)

    def control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        top = 10.0 * self.pendulum.mass_kg * self.pendulum.g_m_s2
        return np.array([-top]), np.array([top])

    def period_bounds(self) -> tuple[float, float]:
        small = 2.0 * math.pi * math.sqrt(self.pendulum.length_m / self.pendulum.g_m_s2)
        return 0.8 * small, 1.4 * small


def pendulum_formulation(p: Pendulum) -> PendulumFormulation:
    """The formulation with scales from the pendulum's own magnitudes."""
    length, speed = p.length_m, math.sqrt(p.g_m_s2 * p.length_m)
    scales = PendulumScales(
        state=np.array([length, length, speed, speed]),
        control=np.array([p.mass_kg * p.g_m_s2]),
        algebraic=np.array([p.g_m_s2, p.g_m_s2, p.mass_kg * p.g_m_s2 / length]),
        fictitious=np.array([p.mass_kg * p.g_m_s2] * 2),
        period_s=2.0 * math.pi * math.sqrt(length / p.g_m_s2),
    )
    return PendulumFormulation(pendulum=p, dae=pendulum_dae(p), scales=scales)


def small_angle_guess(p: Pendulum, times_s: np.ndarray, period_s: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """States and algebraic variables of the small-angle motion ``theta0 cos(2 pi t/T)``
    at ``times_s`` (not a solution at a large release angle: the solver corrects it)."""
    rate = 2.0 * math.pi / period_s
    theta0 = math.radians(p.release_deg)
    th = theta0 * np.cos(rate * times_s)
    dth = -theta0 * rate * np.sin(rate * times_s)
    ddth = -theta0 * rate**2 * np.cos(rate * times_s)
    length = p.length_m
    x = np.vstack([length * np.sin(th), length * np.cos(th),
                   length * dth * np.cos(th), -length * dth * np.sin(th)])
    a_x = length * (ddth * np.cos(th) - dth**2 * np.sin(th))
    a_z = length * (-ddth * np.sin(th) - dth**2 * np.cos(th))
    nu = p.mass_kg * (p.g_m_s2 * np.cos(th) + length * dth**2) / length
    return x, np.vstack([a_x, a_z, nu])


def solved_pendulum(solver: str, transcription: str, codegen: bool = False,
                    n_intervals: int = 20, degree: int = 3, **solver_options: Any) -> tuple:
    """The exact pendulum solved once by ``solver`` on ``transcription`` (with further
    ``SolverOptions`` fields) from its small-angle guess, no control power:
    ``(pendulum, ocp, raw result, parameters)``."""
    from optimize.problem.ocp import assemble, grid_times
    from optimize.problem.options import Discretization, OcpOptions, SolverOptions
    from optimize.solve import nlp_solver

    pendulum = Pendulum()
    form = pendulum_formulation(pendulum)
    ocp = assemble(form, OcpOptions(Discretization(n_intervals, degree), solver=SolverOptions(
        solver=solver, transcription=transcription, codegen=codegen, **solver_options)))
    period = form.scales.period_s
    x, z = small_angle_guess(pendulum, grid_times(ocp, period), period)
    w0 = ocp.pack(x, z[:, 1:], np.zeros((1, n_intervals)),
                  np.zeros((2, n_intervals * degree)), period)
    p = ocp.params(None, {"p_ctrl_w": 0.0})
    bounds = ocp.bounds(drive_limits=False, fix_fictitious=True, period_s=None)
    return pendulum, ocp, nlp_solver.run(ocp, w0, p, bounds, warm=False), p
