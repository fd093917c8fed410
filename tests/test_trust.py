"""Trust checks against independent truths, without an optimization.

The simulation check is fed a trajectory made by a different integrator (a
fine classical RK4 in numpy on the same model equations), packed as if it were
a collocation solution: the check must then find (almost) no defect, and
exactly a defect planted on purpose. The mesh check's interpolation is checked
on fields it must reproduce exactly (linear in time, constant, per-interval).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from system_fixtures import system_for

from optimize.model import kite_model as km
from optimize.paper_model import paper_model
from optimize.problem.guess import LoopGuess, circular_loop
from optimize.problem.ocp import build_ocp, grid_times
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.result import Solution
from optimize.solve.starts.remesh import interpolate_solution
from optimize.sweep.trust import simulation_check

WIND_M_S = 7.0
PERIOD_S = 0.4
N, DEGREE = 4, 3


@dataclass(frozen=True)
class FakeResult:
    scenario: Scenario
    warm: Solution


@pytest.fixture(scope="module")
def ocp():
    dae = km.kite_dae()
    return build_ocp(dae, paper_model(), OcpOptions(Discretization(n_intervals=N, degree=DEGREE)),
        system=system_for())


def controls() -> np.ndarray:
    # small tether jerk and surface rates, different in every interval [m/s^3, rad/s]
    k = np.arange(N)
    return np.vstack([0.5 * (-1.0) ** k, 0.1 + 0.0 * k, -0.05 * k, 0.02 + 0.0 * k])


def rk4_trajectory(ocp) -> np.ndarray:
    """States at the grid points: classical RK4, 400 steps per interval, from the loop guess."""
    f = ocp.dae.explicit_ode
    x = circular_loop(ocp.dae, LoopGuess(), np.array([0.0]), WIND_M_S)[0][:, 0]
    u = controls()
    times = grid_times(ocp, PERIOD_S)
    out, t = [x.copy()], 0.0
    steps_per_interval = 400
    dt = PERIOD_S / N / steps_per_interval

    def rhs(xv, uk):
        return np.asarray(f(xv, uk, WIND_M_S)).ravel()

    for target in times[1:]:
        k = min(int((t + 1e-12) / (PERIOD_S / N)), N - 1)
        while t < target - 1e-12:
            h = min(dt, target - t)
            k1 = rhs(x, u[:, k])
            k2 = rhs(x + h / 2 * k1, u[:, k])
            k3 = rhs(x + h / 2 * k2, u[:, k])
            k4 = rhs(x + h * k3, u[:, k])
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            t += h
        out.append(x.copy())
    return np.array(out).T


def fake_result(ocp, x: np.ndarray) -> FakeResult:
    u = controls()
    u_coll = np.repeat(u, DEGREE, axis=1)
    z = np.asarray(ocp.dae.solve_z.map(x.shape[1] - 1)(x[:, 1:], u_coll, WIND_M_S))
    fict = np.zeros((km.FICTITIOUS.size, N * DEGREE))
    w = ocp.pack(x, z, u, fict, PERIOD_S)
    sol = Solution(w=w, lam_x=np.zeros_like(w), lam_g=np.zeros(1), n_intervals=N, degree=DEGREE)
    return FakeResult(Scenario(WIND_M_S, "electrical", True), sol)


def test_simulation_check_reproduces_an_independent_rk4_trajectory(ocp):
    x = rk4_trajectory(ocp)
    check = simulation_check(ocp, fake_result(ocp, x))
    # RK4 with 0.25 ms steps has a global error far below 1e-6 m over 0.4 s; CVODES runs at
    # 1e-10 tolerances: 1e-5 m leaves room for both and is still 4 orders below a real defect
    assert check.interval_defect_position_m < 1e-5
    assert check.open_loop_position_m < 1e-5
    assert check.interval_defect_scaled < 1e-5
    # periodicity error of the open-loop run = |x(T) - x(0)| of the RK4 run (not periodic here)
    per = km.STATES.indices(km.PERIODIC_STATES)
    want = np.max(np.abs(x[per, -1] - x[per, 0]) / ocp.scales.state[per])
    assert check.periodicity_error_scaled == pytest.approx(want, rel=1e-4)
    yz = km.STATES.indices(("r_y_m", "r_z_m"))
    assert check.periodicity_error_position_m == pytest.approx(
        np.linalg.norm(x[yz, -1] - x[yz, 0]), rel=1e-4
    )


def test_simulation_check_finds_a_planted_defect(ocp):
    x = rk4_trajectory(ocp)
    x[km.STATES.index("r_x_m"), 1 * DEGREE + 2] += 0.5  # interval 1, its second Radau point, 0.5 m
    check = simulation_check(ocp, fake_result(ocp, x))
    # the simulation does not follow the planted jump: the defect is the jump itself
    assert check.interval_defect_position_m == pytest.approx(0.5, abs=1e-4)
    assert check.open_loop_position_m == pytest.approx(0.5, abs=1e-4)


def test_mesh_interpolation_is_exact_on_linear_states_and_interval_controls(ocp):
    fine = build_ocp(ocp.dae, paper_model(),
                     OcpOptions(Discretization(n_intervals=2 * N, degree=DEGREE)),
                         system=system_for())
    t_c = grid_times(ocp, PERIOD_S)
    slope = np.linspace(-2.0, 3.0, km.STATES.size)[:, None]
    x = 1.0 + slope * t_c[None, :]
    z = np.tile(np.linspace(1.0, 7.0, km.ALGEBRAIC.size)[:, None], (1, N * DEGREE))
    u = controls()
    w = ocp.pack(x, z, u, np.zeros((km.FICTITIOUS.size, N * DEGREE)), PERIOD_S)
    sol = Solution(w=w, lam_x=w, lam_g=np.zeros(1), n_intervals=N, degree=DEGREE)
    got = fine.unpack(interpolate_solution(ocp, sol, fine))
    t_f = grid_times(fine, PERIOD_S)
    assert got["period_s"] == pytest.approx(PERIOD_S, rel=1e-14)
    np.testing.assert_allclose(got["x"], 1.0 + slope * t_f[None, :], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got["z"], np.tile(z[:, :1], (1, 2 * N * DEGREE)), rtol=1e-12)
    # fine intervals 2k and 2k+1 lie inside coarse interval k
    np.testing.assert_array_equal(got["u"], np.repeat(u, 2, axis=1))
    assert not np.any(got["fict"])


def test_mesh_check_reaches_the_fine_grids_own_optimum(coarse_ocp, coarse_elec_lim, paper_ocp,
                                                        stored_guess_solve):
    """The mesh check re-solves a coarse optimum (N = 10) on the 40-interval grid from
    its interpolation; the fine optimum it reaches equals the one IPOPT reaches from the
    shipped initial guess, an independent start on the same grid (0.05 W, 0.01 s)."""
    from optimize.sweep.trust import mesh_check

    assert coarse_elec_lim.success and stored_guess_solve.success
    assert stored_guess_solve.scenario == coarse_elec_lim.scenario  # elec-lim at 7 m/s
    check = mesh_check(coarse_ocp, paper_ocp, coarse_elec_lim.scenario, coarse_elec_lim)
    assert check.success and check.route == "interpolated warm start", check
    assert (check.n_intervals, check.n_intervals_fine) == (coarse_ocp.n_intervals, 40)
    assert check.avg_p_elec_fine_w == pytest.approx(stored_guess_solve.avg_p_elec_w, abs=0.05)
    assert check.avg_p_mech_fine_w == pytest.approx(stored_guess_solve.avg_p_mech_w, abs=0.05)
    assert check.period_fine_s == pytest.approx(stored_guess_solve.period_s, abs=0.01)
