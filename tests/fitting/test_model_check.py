"""A physically impossible power model is refused before any solve (issue 13 section 2)."""

from __future__ import annotations

import dataclasses

import pytest
from fit_synthetic import paper_quadratic, synthetic_points

from bench.cli import main
from bench.errors import InputError
from fitting.domain import quadrant_envelopes
from fitting.model_check import check_physics, physics_problems
from fitting.model_file import save_power_model
from fitting.points import quadrant_of
from fitting.power_fit import fit_power_model
from fitting.terms import full_polynomial
from optimize.paper_model import paper_model

A0, A1, A2, A3 = paper_model().coefficients_rpm


def _with(coefs, domain="keep"):
    m = paper_model()
    kw = {"coefficients_rpm": tuple(coefs), "covariance_rpm": None}
    if domain != "keep":
        kw["domain"] = domain
    return dataclasses.replace(m, **kw)


def test_paper_model_passes():
    """Paper Table I: losses 293.6 W + ... > 0 over the bench range (docs/paper_figures.md §1)."""
    assert physics_problems(paper_model()) == []
    assert physics_problems(_with(paper_model().coefficients_rpm, domain=None),
                            limits=(1500.0, 78.0)) == []


@pytest.mark.parametrize("order", [2, 3, 4])
def test_fitted_models_pass(order):
    """Full polynomials fitted to noisy points (40 W) around the paper's model, over the
    envelopes of those points as bench fit exports them, are possible drives."""
    frame = synthetic_points(paper_quadratic)
    frame["quadrant"] = quadrant_of(frame["p_mech_w"].to_numpy())
    fit = fit_power_model(frame["speed_rpm"].to_numpy(), frame["torque_nm"].to_numpy(),
                          frame["p_elec_w"].to_numpy(), full_polynomial(order),
                          nominal_power_w=8200.0)
    domain = {q: env["polygon"] for q, env in quadrant_envelopes(frame).items()}
    model = fit.to_power_model(f"order {order}", domain=domain)
    assert physics_problems(model) == []


@pytest.mark.parametrize(("coefs", "words"), [
    ((A0, A1, -0.5, A3), "negative losses"),  # negative T^2 coefficient
    ((-1e6, A1, A2, A3), "negative losses"),  # c0 = -1 MW
    ((0.0, 0.0, 0.0, 0.0), "negative losses"),  # a drive without losses or power
    ((A0, 1e250, A2, A3), "implausible"),  # 1e250: |P_elec| ~ 1e256 W
    ((A0 + 1e6, A1, A2, A3), "implausible"),  # 1 MW of standby losses for an 8.2 kW drive
])
def test_impossible_models_are_named(coefs, words):
    problems = physics_problems(_with(coefs))
    assert problems and any(words in p for p in problems), problems
    with pytest.raises(InputError, match="physically impossible power model"):
        check_physics(_with(coefs), "m.json")


def test_constant_model_without_motor_quadrant():
    """Generator domain only: a constant model has no negative losses there, yet it does
    not depend on the operating point."""
    gen = {"generator": paper_model().domain["generator"]}
    problems = physics_problems(_with((100.0, 0.0, 0.0, 0.0), domain=gen))
    assert problems and "does not depend" in problems[0]


def test_optimize_refuses_before_solving(tmp_path, capsys):
    bad = tmp_path / "bad_model.json"
    save_power_model(_with((A0, A1, -0.5, A3)), bad)
    out = tmp_path / "opt"
    rc = main(["optimize", "--drive-model", str(bad), "--wind-grid", "7", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    assert str(bad) in err and "negative losses" in err
    assert not out.exists()
