"""The tangential predictor (optimize/solve/starts/predictor.py): the derivative of an optimum in
the wind speed against two converged optima, and a predicted start's solve."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from system_fixtures import system_for

from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve
from optimize.solve.starts.predictor import tangent

#: a wind step small enough for the first-order prediction to dominate [m/s]
STEP_M_S = 0.05


@pytest.fixture(scope="module")
def neighbours(coarse_ocp, coarse_mechanical):
    """The coarse OCP's mech-free optima at 7 m/s and at 7 m/s + STEP_M_S."""
    s0 = coarse_mechanical.scenario
    s1 = Scenario(s0.wind_speed_m_s + STEP_M_S, s0.objective, s0.drive_limits)
    far = solve(coarse_ocp, s1, coarse_mechanical.warm)
    assert far.success
    return coarse_mechanical, far


def _params(ocp, result):
    s = result.scenario
    return (ocp.params(s.parameters, s.weights),
            ocp.bounds(drive_limits=s.drive_limits, fix_fictitious=True, period_s=None))


def test_tangent_against_two_optima(coarse_ocp, neighbours):
    """w* + dw/dp dp is closer to the optimum at 7.05 m/s than w* is, by a factor of
    at least 5 (the finite difference of two optima converged to IPOPT's tol 1e-6 holds
    the second-order term and the solves' own error); the row multipliers likewise by 3."""
    near, far = neighbours
    (p0, b0), (p1, _) = _params(coarse_ocp, near), _params(coarse_ocp, far)
    tg = tangent(coarse_ocp, near.warm.w, near.warm.lam_x, near.warm.lam_g, p0, p1 - p0, b0)
    moved = far.warm.w - near.warm.w
    assert np.linalg.norm(moved - tg.dw) < np.linalg.norm(moved) / 5
    dlam = far.warm.lam_g - near.warm.lam_g
    assert np.linalg.norm(dlam - tg.dlam_g) < np.linalg.norm(dlam) / 3


@pytest.fixture(scope="module")
def predicting_ocp(coarse_ocp):
    """The coarse OCP with ``predictor_step = 1`` (the same layout as ``coarse_ocp``)."""
    from optimize.model.kite_model import kite_dae
    from optimize.paper_model import paper_model
    from optimize.problem.ocp import build_ocp

    return build_ocp(kite_dae(), paper_model(),
                     coarse_ocp.options.replace(solver={"predictor_step": 1.0}),
                         system=system_for())


def test_predicted_start_solves_to_the_same_optimum(predicting_ocp, neighbours):
    """With ``predictor_step`` set, ``solve`` starts from the prediction (stage
    ``"predicted"``) and converges to the optimum the neighbour's own point gives
    (objective within 1e-6 of the power scale), in no more iterations on this small
    step; without it the stage is the plain ``"warm"``."""
    near, far = neighbours
    assert far.stages[0]["stage"] == "warm"
    res = solve(predicting_ocp, far.scenario, near.warm, retry_cold=False)
    assert res.stages[0]["stage"] == "predicted"
    assert res.success
    assert res.objective == pytest.approx(far.objective, abs=1e-6)
    assert res.iterations <= far.iterations
    assert res.warm.p is not None and res.warm.drive_limits is False


def test_no_prediction_without_the_neighbours_parameters(predicting_ocp, neighbours):
    """A warm start that does not know its parameters (a stored or carried-over solve)
    is used as it is, and converges to the same optimum."""
    near, far = neighbours
    res = solve(predicting_ocp, far.scenario, replace(near.warm, p=None), retry_cold=False)
    assert res.stages[0]["stage"] == "warm"
    assert res.objective == pytest.approx(far.objective, abs=1e-6)
