"""The envelope-theorem band against a finite-difference re-solve of a real (coarse) OCP."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from energy.bands import basis_averages
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve

N_COARSE = 10  # coarse but converging grid: the three solves take ~15 s on 2 busy cores


def test_sigma_equals_finite_difference_re_solve(coarse_ocp, coarse_elec_lim):
    # A covariance with correlated 2 % coefficient errors. Along d = Sigma g / sigma the
    # envelope theorem gives dP*/dh = g . d = sigma. Re-optimizing at a +- h d and taking
    # the central difference must give the same slope: the O(h^2) term cancels, the
    # solver tolerance (1e-6 on kW) is ~1e-3 W against a ~130 W difference, so 1 %.
    model = paper_model()
    c = np.array(model.coefficients_rpm)
    s = 0.02 * np.abs(c)
    cov = 0.3 * np.outer(s, s) + 0.7 * np.diag(s**2)
    # the base cycle: the coarse paper OCP's elec-lim optimum, shared (conftest.py)
    dae, options, base = coarse_ocp.dae, coarse_ocp.options, coarse_elec_lim
    assert options.discretization.n_intervals == N_COARSE
    assert coarse_ocp.drive_model.coefficients_rpm == model.coefficients_rpm
    scenario = Scenario(7.0, "electrical", True)
    assert base.success, base.status
    g = basis_averages(base.trajectory, model)
    assert float(g @ c) == pytest.approx(base.avg_p_elec_w, rel=1e-9)  # the model on the cycle
    assert model.of_basis(g) == float(g @ c)
    sig = dataclasses.replace(model, covariance_rpm=tuple(map(tuple, cov))).sigma_of_basis(g)
    assert sig == pytest.approx(float(np.sqrt(g @ cov @ g)), rel=1e-12)
    d = cov @ g / sig
    h = 3.0  # three sigmas each way
    p = {}
    for sign in (1, -1):
        perturbed = dataclasses.replace(model, coefficients_rpm=tuple(c + sign * h * d),
                                        covariance_rpm=None)
        ocp = build_ocp(dae, perturbed, options, system=coarse_ocp.system)
        res = solve(ocp, scenario, base.warm)
        assert res.success, res.status
        p[sign] = res.avg_p_elec_w
    assert (p[1] - p[-1]) / (2 * h) == pytest.approx(sig, rel=0.01)
