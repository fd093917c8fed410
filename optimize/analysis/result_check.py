"""A cheap physical check of every converged optimum, whatever the solver said.

Three figures per optimum, each with a verdict (:func:`check_result`):

* **Power bound.** Over a periodic cycle the kite's kinetic and potential energy
  come back to their start, so the average power at the tether is the average
  power of the aerodynamic force in the ground frame. With the air-relative
  velocity ``v_a``, the local wind ``w``, the resultant aerodynamic force
  ``F = q S C_R`` and its drag component ``D = q S C_D`` (``q = rho v_a^2 / 2``),
  that power is ``F . w - D |v_a| <= q S (C_R w - C_D v_a)``, largest at
  ``v_a = 2 C_R w / (3 C_D)``:

  ``P <= (2/27) rho S w^3 C_R^3 / C_D^2``

  which is Loyd's crosswind bound (M. L. Loyd, "Crosswind kite power", J. Energy
  4(3), 1980, pp. 106-111) with the resultant coefficient ``C_R`` for ``C_L``.
  The check takes the kite's own coefficients (its aerodynamic model at zero
  rates), the largest ``C_R^3 / C_D^2`` over the angle-of-attack, sideslip and
  control-surface bounds in force, the wing's drag alone (the tether's drag only
  lowers the bound while ``C_D < sqrt(2) C_L``), its reference area and air
  density, and the largest wind speed at the kite over the cycle. An optimum whose
  average generated mechanical power (at the drum, below the kite's) exceeds this
  bound is physically impossible.
* **Collocation error.** Each collocation interval is integrated again from the
  collocation state at its start with the optimal (piecewise-constant) controls by
  classical Runge-Kutta on a finer grid (at least :data:`SUBSTEPS_PER_POINT` steps
  per collocation point, steps of at most :data:`MAX_STEP_S`); the largest
  difference at the interval ends, each state divided by its typical magnitude
  (the OCP's scales), is the collocation's discretization error. Above
  :data:`MAX_DEFECT_SCALED` the cycle is not a solution of the dynamics.
* **Periodicity of the re-integration.** The last interval's re-integrated end
  against the cycle's start on the periodic states (the same scaling). Above
  :data:`MAX_DEFECT_SCALED` the cycle does not close.

Meshes coarser than :data:`MIN_COLLOCATION_POINTS` collocation points per cycle
(intervals times degree) are flagged; the check decides whether their optimum
stands. The open-loop run of the whole period from ``x(0)`` (``--trust``) is not
part of the verdict: the kite is open-loop unstable, so it measures the dynamics'
amplification of the collocation error as much as the error itself.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np

from optimize.model.aero import force_coefficients
from optimize.problem.kite_part import POSITION_STATES
from optimize.problem.options import MIN_COLLOCATION_POINTS

#: largest accepted interval defect and periodicity error, in state scales [-]
MAX_DEFECT_SCALED = 0.05
#: re-integration: Runge-Kutta steps per collocation point, at least
SUBSTEPS_PER_POINT = 4
#: re-integration: longest Runge-Kutta step [s]
MAX_STEP_S = 0.01
#: grid points per coefficient bound for the largest C_R^3 / C_D^2
_GRID = (41, 7, 7, 7, 7)


@dataclass(frozen=True)
class ResultCheck:
    """The verdict of :func:`check_result` on one optimum.

    Attributes
    ----------
    scenario : str
    mesh : str
        ``"<N> intervals x degree <d>"`` and, below the documented minimum, a flag.
    generated_w : float
        Average mechanical power generated over the cycle (``-avg_p_mech_w``) [W].
    power_bound_w : float
        The Loyd-type bound on it [W].
    wind_max_m_s : float
        Largest wind speed at the kite over the cycle [m/s].
    defect_scaled : float
        Largest interval-end difference of the re-integration [-] (state scales).
    defect_position_m : float
        The same in position [m].
    periodicity_scaled : float
        Re-integrated end of the cycle against its start, periodic states [-].
    reasons : tuple of str
        Why the optimum fails (empty: it passes).
    wall_time_s : float
        Time the check took [s].
    """

    scenario: str
    mesh: str
    generated_w: float
    power_bound_w: float
    wind_max_m_s: float
    defect_scaled: float
    defect_position_m: float
    periodicity_scaled: float
    reasons: tuple[str, ...]
    wall_time_s: float = 0.0

    @property
    def passed(self) -> bool:
        """No reason to reject the optimum."""
        return not self.reasons

    def verdict(self) -> str:
        """``"passed"`` or ``"failed: <reasons>"`` (the summary's ``result_check``)."""
        return "passed" if self.passed else "failed: " + "; ".join(self.reasons)


def mesh_label(n_intervals: int, degree: int) -> str:
    """The mesh, flagged when coarser than :data:`MIN_COLLOCATION_POINTS`."""
    label = f"{n_intervals} intervals x degree {degree}"
    if n_intervals * degree < MIN_COLLOCATION_POINTS:
        label += (f" (below the documented minimum of {MIN_COLLOCATION_POINTS} collocation "
                  "points per cycle)")
    return label


def max_force_ratio(coeffs: Any, system: Any) -> float:
    """Largest ``C_R^3 / C_D^2`` of the wing within the OCP's bounds [-].

    Grid over angle of attack, sideslip and the three surface deflections (the ranges of
    ``system``'s ``[aero]`` and ``[bounds]``); the wing's drag alone, no tether drag.
    """
    aero = system.aero
    a_lo, a_hi = np.radians((aero.alpha_min_deg, aero.alpha_max_deg))
    b_lo, b_hi = np.radians((aero.beta_min_deg, aero.beta_max_deg))
    s_a, s_e, s_r = np.radians(system.bounds.surface_bounds_deg())
    axes = [np.linspace(lo, hi, n) for (lo, hi), n in
            zip(((a_lo, a_hi), (b_lo, b_hi), (-s_a, s_a), (-s_e, s_e), (-s_r, s_r)), _GRID,
                strict=True)]
    alpha, beta, ail, elev, rud = np.meshgrid(*axes, indexing="ij", sparse=True)
    cl, cd, cy = force_coefficients(alpha, beta, (ail, elev, rud), coeffs)
    cd = np.broadcast_to(cd, np.broadcast_shapes(np.shape(cl), np.shape(cd), np.shape(cy)))
    cr2 = cl**2 + cd**2 + cy**2
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(cd > 0, cr2**1.5 / cd**2, np.inf)
    return float(np.max(ratio))


def power_bound_w(rho_kg_m3: float, sref_m2: float, wind_m_s: float, ratio: float) -> float:
    """Loyd-type bound ``(2/27) rho S w^3 C_R^3 / C_D^2`` on the average power [W]."""
    return 2.0 / 27.0 * rho_kg_m3 * sref_m2 * wind_m_s**3 * ratio


@lru_cache(maxsize=8)
def _rk4_step(dae: Any) -> ca.Function:
    """One classical Runge-Kutta step ``(x, [u; wind; dt]) -> x`` of the explicit ODE."""
    nu = dae.controls.size
    x = ca.MX.sym("x", dae.states.size)
    p = ca.MX.sym("p", nu + 2)
    u, wind, dt = p[:nu], p[nu], p[nu + 1]

    def f(y):
        return dae.explicit_ode(y, u, wind)

    k1 = f(x)
    k2 = f(x + dt / 2 * k1)
    k3 = f(x + dt / 2 * k2)
    k4 = f(x + dt * k3)
    return ca.Function("rk4_step", [x, p], [x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])


def reintegrate(ocp: Any, result: Any) -> tuple[float, float, float]:
    """Interval defect (scaled, position [m]) and periodicity of the re-integration.

    Each interval from its collocation start state with its control, on a finer
    Runge-Kutta grid (see the module docstring).
    """
    sol = ocp.unpack(result.warm.w)
    x_c, u = np.asarray(sol["x"]), np.asarray(sol["u"])
    n, d = ocp.n_intervals, ocp.coll.degree
    h = sol["period_s"] / n
    steps = max(SUBSTEPS_PER_POINT * d, math.ceil(h / MAX_STEP_S))
    run = _rk4_step(ocp.dae).fold(steps)
    scale = ocp.scales.state
    per, pos = ocp.dae.states.indices(ocp.dae.periodic), ocp.dae.states.indices(POSITION_STATES)
    wind = result.scenario.wind_speed_m_s
    defect = defect_pos = 0.0
    x_end = x_c[:, 0]
    for k in range(n):
        par = np.append(u[:, k], [wind, h / steps])
        x_end = np.asarray(run(x_c[:, k * d], np.tile(par[:, None], steps))).ravel()
        target = x_c[:, (k + 1) * d]
        if not np.all(np.isfinite(x_end)):
            return math.inf, math.inf, math.inf
        defect = max(defect, float(np.max(np.abs(x_end - target) / scale)))
        defect_pos = max(defect_pos, float(np.linalg.norm(x_end[pos] - target[pos])))
    periodicity = float(np.max(np.abs(x_end[per] - x_c[per, 0]) / scale[per]))
    return defect, defect_pos, periodicity


def check_result(ocp: Any, result: Any, name: str) -> ResultCheck:
    """Power bound, collocation error and periodicity of one converged optimum.

    Parameters
    ----------
    ocp : optimize.problem.ocp.Ocp
        The OCP the optimum was solved on.
    result : optimize.solve.result.OcpResult
        A converged result.
    name : str
        The scenario's name (for the record).
    """
    t0 = time.perf_counter()
    kite, traj = ocp.dae.kite, result.trajectory
    wind_max = float(np.max(traj["wind_m_s"]))
    bound = power_bound_w(kite.rho_kg_m3, kite.sref_m2, wind_max,
                          max_force_ratio(ocp.dae.coeffs, ocp.system))
    generated = -float(result.avg_p_mech_w)
    defect, defect_pos, periodicity = reintegrate(ocp, result)
    mesh = mesh_label(ocp.n_intervals, ocp.coll.degree)
    reasons = []
    if not generated <= bound:
        reasons.append(f"{generated:.0f} W generated, above the {bound:.0f} W the wind can "
                       f"give this kite (Loyd-type bound at {wind_max:.2f} m/s at the kite)")
    if not math.isfinite(defect):
        reasons.append("the dynamics re-integrated on a finer grid diverge within an interval "
                       "(the collocation states are no solution of them)")
    elif not defect <= MAX_DEFECT_SCALED:
        reasons.append(f"the dynamics re-integrated on a finer grid leave the collocation "
                       f"states by {defect:.3g} state scales ({defect_pos:.3g} m) within an "
                       f"interval (limit {MAX_DEFECT_SCALED})")
    if math.isfinite(defect) and not periodicity <= MAX_DEFECT_SCALED:
        reasons.append(f"the re-integrated cycle does not close ({periodicity:.3g} state "
                       f"scales, limit {MAX_DEFECT_SCALED})")
    if reasons:
        reasons.append(f"mesh {mesh}")
    return ResultCheck(name, mesh, generated, bound, wind_max, defect, defect_pos,
                       periodicity, tuple(reasons), time.perf_counter() - t0)
