"""Starting an OCP with the winding temperature from the same problem without it.

An OCP whose formulation adds the winding temperature to the kite's state
(:func:`optimize.problem.ocp.build_ocp` with a thermal rating) keeps the problem
without it as ``ocp.base``. A cold start solves ``base`` (stored guess or homotopy),
adds to its optimum the cyclic steady temperature of its losses
(:func:`optimize.model.thermal.periodic_temperatures`, the copper term at that
temperature by a fixed-point iteration) and solves the full problem from there.
"""

from __future__ import annotations

import numpy as np

from optimize.model.thermal import periodic_temperatures
from optimize.problem.ocp import Ocp
from optimize.solve.result import Solution, carry_over

#: fixed-point iterations of the temperature and the copper losses at it
ITERATIONS = 4


def temperature_guess(ocp: Ocp, solution: Solution, wind_speed_m_s: float) -> np.ndarray:
    """The thermal nodes' temperatures [degC] at the state grid of ``ocp.base``'s
    ``solution``, ``(nodes, N d + 1)``, the winding first.

    Parameters
    ----------
    ocp : Ocp
        The problem with the winding temperature (``ocp.base`` set).
    solution : Solution
        An optimum of ``ocp.base``.
    wind_speed_m_s : float
        Its wind speed [m/s].
    """
    base, thermal = ocp.base, ocp.formulation.thermal
    sol = base.unpack(solution.w)
    n, d = base.n_intervals, base.coll.degree
    x, z = sol["x"][:, 1:], sol["z"]
    out = base.formulation.trajectory_outputs(x, np.repeat(sol["u"], d, axis=1), z,
                                              wind_speed_m_s)
    heat0 = out["p_elec_w"] - out["p_mech_w"]
    h = sol["period_s"] / n
    times = h * (np.repeat(np.arange(n), d) + np.tile(base.coll.tau[1:], n))
    times = np.concatenate([[0.0], times[:-1]])  # the last Radau point is the period's end
    theta = np.full(n * d, thermal.steady_c(float(np.mean(heat0))))
    for _ in range(ITERATIONS):
        heat = heat0 + thermal.copper_drift_w(out["torque_nm"], theta)
        at = periodic_temperatures(times, np.roll(heat, 1), sol["period_s"], thermal)
        nodes = np.roll(at, -1, axis=1)  # back to the Radau points (the end is the start)
        theta = nodes[0]
    return np.hstack([nodes[:, -1:], nodes])


def warm_from_base(ocp: Ocp, solution: Solution, wind_speed_m_s: float) -> Solution:
    """``ocp.base``'s ``solution`` in ``ocp``'s layout with its winding temperature."""
    theta = temperature_guess(ocp, solution, wind_speed_m_s)
    return carry_over(ocp.base, solution, ocp, added_x=theta)
