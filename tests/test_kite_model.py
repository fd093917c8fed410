"""Kite DAE: kinematics of an exact loop, invariants and DCM orthonormality in simulation."""

import casadi as ca
import numpy as np
import pytest

from optimize.model import kite_model as km
from optimize.problem.guess import LoopGuess, circular_loop


@pytest.fixture(scope="module")
def dae():
    return km.kite_dae()


def test_ode_matches_exact_loop_derivatives(dae):
    # Truth: the analytic circular loop (rigid rotation). The ODE evaluated with the
    # loop's exact accelerations must equal the central finite difference of the states
    # (h = 1e-5 s: truncation ~ h^2 * 3rd derivative ~ 1e-8, so 1e-6 is a safe bound).
    guess = LoopGuess()
    t, h = np.array([0.7, 2.9]), 1e-5
    x, z, _ = circular_loop(dae, guess, t, 7.0)
    xp, _, _ = circular_loop(dae, guess, t + h, 7.0)
    xm, _, _ = circular_loop(dae, guess, t - h, 7.0)
    for i in range(len(t)):
        xdot = np.asarray(dae.ode(x[:, i], np.zeros(km.CONTROLS.size), z[:, i])).ravel()
        np.testing.assert_allclose(xdot, (xp[:, i] - xm[:, i]) / (2 * h), atol=1e-6)
        c, cdot, orth = dae.invariants(x[:, i])
        assert abs(float(c)) < 1e-9 and abs(float(cdot)) < 1e-9
        assert np.abs(np.asarray(orth)).max() < 1e-12


def test_fictitious_forces_close_the_loop_residual(dae):
    # the guess's fictitious forces make the algebraic residual exactly zero
    x, z, fict = circular_loop(dae, LoopGuess(), np.array([1.3]), 7.0)
    res = np.asarray(dae.alg(x[:, 0], np.zeros(km.CONTROLS.size), z[:, 0], 7.0, fict[:, 0])).ravel()
    assert np.abs(res).max() < 1e-8


def test_solved_algebraic_variables_satisfy_residual(dae):
    x, _, _ = circular_loop(dae, LoopGuess(), np.array([0.4]), 6.0)
    u = np.array([3.0, 0.1, -0.2, 0.3])
    z = np.asarray(dae.solve_z(x[:, 0], u, 6.0)).ravel()
    res = np.asarray(dae.alg(x[:, 0], u, z, 6.0, np.zeros(km.FICTITIOUS.size))).ravel()
    # residual rows are N, N m and m^2/s^2 of size ~1e3: 1e-8 is round-off level
    assert np.abs(res).max() < 1e-8


def test_invariants_and_orthonormality_preserved_in_simulation(dae):
    # Simulate 2 s of free flight (constant tether jerk and surface rates, 7 m/s wind)
    # from a consistent state with CVODES at tight tolerances. The model enforces
    # d2c/dt2 = 0 only, so c and dc/dt drift by integration error alone; the DCM
    # obeys Rdot = R [w]x, which keeps R^T R = I exactly in continuous time.
    x, _, _ = circular_loop(dae, LoopGuess(period_s=4.0), np.array([0.0]), 7.0)
    x0 = x[:, 0]
    xs, us, wind = ca.SX.sym("x", km.STATES.size), ca.SX.sym("u", km.CONTROLS.size), ca.SX.sym("w")
    ode = {"x": xs, "p": ca.vertcat(us, wind), "ode": dae.explicit_ode(xs, us, wind)}
    times = np.linspace(0.0, 2.0, 21)
    sim = ca.integrator("sim", "cvodes", ode, 0.0, times[1:],
                        {"abstol": 1e-11, "reltol": 1e-11})
    u = np.array([0.5, 0.02, -0.01, 0.02])
    traj = np.asarray(sim(x0=x0, p=np.concatenate([u, [7.0]]))["xf"])
    moved = np.linalg.norm(traj[:3, -1] - x0[:3])
    assert moved > 20.0  # the kite really flew (about 25 m/s for 2 s)
    for k in range(traj.shape[1]):
        c, cdot, orth = dae.invariants(traj[:, k])
        # c ~ l^2 ~ 6e3 m^2 and dc/dt ~ l v ~ 2e3 m^2/s: 1e-5 is ~1e-9 relative,
        # a hundred times the tolerance of the integrator
        assert abs(float(c)) < 1e-5
        assert abs(float(cdot)) < 1e-5
        assert np.abs(np.asarray(orth)).max() < 1e-8
