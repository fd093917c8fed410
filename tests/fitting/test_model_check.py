"""A physically impossible power model is refused before any solve (issue 13 section 2)."""

from __future__ import annotations

import dataclasses

import pytest
from fit_synthetic import paper_quadratic, synthetic_points

from drivebench.cli import main
from fitting.domain import quadrant_envelopes
from fitting.model_check import check_physics, physics_problems
from fitting.model_file import save_power_model
from fitting.points import quadrant_of
from fitting.power_fit import fit_power_model
from fitting.terms import full_polynomial
from kernel.errors import InputError
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


LIMITS = (1500.0, 78.0)  # the drive limits in force in these cases (rating of the paper drive)


def _nominal(model, nominal_w):
    """``model`` claiming ``nominal_w`` (in its drive rating too)."""
    drive = {**(model.drive.to_dict() if model.drive else {}), "nominal_power_w": nominal_w}
    return dataclasses.replace(model, nominal_power_w=nominal_w, drive=drive)


def test_impossibility_outside_the_measured_domain_is_found():
    """A w*T coefficient of 0.2 (rpm units: P_elec = 1.9 P_mech) fitted on a motor-only
    campaign: possible in the motor quadrant, but the optimizer may generate, where the
    drive would create 2.2 kW. Refused, the generator quadrant within the limits named."""
    motor_only = {"motor": paper_model().domain["motor"]}
    model = _with((A0, A1, A2, 0.2), domain=motor_only)
    assert physics_problems(model) == []  # the measured domain alone hides it
    problems = physics_problems(model, limits=LIMITS)
    assert len(problems) == 1 and problems[0].startswith("generator quadrant within the drive")
    assert "negative losses" in problems[0]
    # independent value: at -1500 rpm, 78 N m the losses are 0.9 P_mech + A0 + A1 n^2 + A2 T^2
    p_mech = -1500 * 2 * 3.141592653589793 / 60 * 78
    loss = A0 + A1 * 1500**2 + A2 * 78**2 + (0.2 - 2 * 3.141592653589793 / 60) * -1500 * 78
    assert loss < -0.5 * abs(p_mech)
    assert f"{loss:.4g}" in problems[0]


def test_small_domain_does_not_hide_a_negative_t2():
    """T^2 = -0.3 with a 100 rpm x 5 N m measured domain: fine there (losses > 0), refused
    over the limits (-0.3 * 78^2 = -1825 W at full torque)."""
    box = [[0.0, 0.0], [100.0, 0.0], [100.0, 5.0], [0.0, 5.0]]
    model = _with((A0, A1, -0.3, A3), domain={"motor": box})
    assert physics_problems(model) == []
    problems = physics_problems(model, limits=LIMITS)
    assert problems and all("negative losses" in p for p in problems)


def test_large_nominal_power_does_not_hide_negative_losses():
    """T^2 = -0.5 with nominal_power_w 1e7: the tolerance comes from the model's losses,
    not the claimed nominal power; refused with negative losses named (not described as
    a model that does not depend on speed and torque, also at nominal 1e12)."""
    for nominal in (1e7, 1e12):
        model = _nominal(_with((A0, A1, -0.5, A3)), nominal)
        problems = physics_problems(model, limits=LIMITS)
        assert problems and all("negative losses" in p for p in problems), problems
        assert not any("does not depend" in p for p in problems)


@pytest.mark.parametrize("order", [2, 3])
def test_fitted_models_pass_over_the_limits(order):
    """Models fitted on both quadrants (40 W noise) pass over the whole limits box too."""
    frame = synthetic_points(paper_quadratic)
    fit = fit_power_model(frame["speed_rpm"].to_numpy(), frame["torque_nm"].to_numpy(),
                          frame["p_elec_w"].to_numpy(), full_polynomial(order),
                          nominal_power_w=8200.0)
    assert physics_problems(fit.to_power_model(f"order {order}"), limits=LIMITS) == []


def test_optimize_refuses_a_motor_only_model_that_generates_energy(tmp_path, capsys):
    bad = tmp_path / "motor_only.json"
    model = _with((A0, A1, A2, 0.2), domain={"motor": paper_model().domain["motor"]})
    save_power_model(model, bad)
    rc = main(["optimize", "--drive-model", str(bad), "--wind-grid", "7",
               "--out", str(tmp_path / "opt")])
    err = capsys.readouterr().err
    assert rc == 2 and "generator quadrant within the drive limits" in err
