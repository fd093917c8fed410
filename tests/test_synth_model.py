"""The synthetic truth's loss model, thermal model and calibration, against hand calculations."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from bench.synth.loss_model import (
    DEFAULT_MODEL,
    PAPER_QUADRATIC,
    LossModel,
    calibrate_core,
    fan_power_w,
    fit_quadratic,
    loss_w,
    theta_step,
    true_p_elec_w,
)

# the paper's quadratic alone: every extra effect switched off
BARE = dataclasses.replace(
    DEFAULT_MODEL, friction_w_s_per_rad=0.0, iron_w_per_rpm1p6=0.0, gear_loss_fraction=0.0,
    fan_max_w=0.0,
)


def test_bare_model_is_the_paper_quadratic():
    # docs/paper_figures.md §1 sanity values, quoted to 3-4 significant digits there
    p_gen = true_p_elec_w(-1500.0, 78.0, model=BARE)
    assert p_gen == pytest.approx(-11040.0, abs=10.0)
    assert true_p_elec_w(-50.0, 78.0, model=BARE) == pytest.approx(279.0, abs=1.0)
    a0, a1, a2, a3 = PAPER_QUADRATIC
    n, t = 1234.0, 56.7
    assert true_p_elec_w(n, t, model=BARE) == pytest.approx(a0 + a1 * n**2 + a2 * t**2 + a3 * n * t,
                                                            rel=1e-12)


def test_each_extra_effect_by_hand():
    n, t = -2000.0, 30.0
    omega = n * np.pi / 30.0  # -209.44 rad/s
    base = float(true_p_elec_w(n, t, model=BARE))
    cases = {
        "friction_w_s_per_rad": (0.5, 0.5 * abs(omega)),
        "iron_w_per_rpm1p6": (4e-4, 4e-4 * 2000.0**1.6),
        "gear_loss_fraction": (0.01, 0.01 * abs(omega * t)),
    }
    for field, (value, extra) in cases.items():
        model = dataclasses.replace(BARE, **{field: value})
        assert true_p_elec_w(n, t, model=model) - base == pytest.approx(extra, rel=1e-12), field
    # copper drift: +100 K on a copper-only T^2 term raises it by alpha_cu * 100 = 39.3 %
    hot = true_p_elec_w(n, t, theta_c=BARE.theta_ref_c + 100.0, model=BARE)
    assert hot - base == pytest.approx(0.393 * PAPER_QUADRATIC[2] * t**2, rel=1e-9)


def test_fan_ramps_between_its_temperatures():
    m = DEFAULT_MODEL
    mid = 0.5 * (m.fan_start_c + m.fan_full_c)
    np.testing.assert_allclose(
        fan_power_w([m.fan_start_c - 5.0, mid, m.fan_full_c + 5.0], m),
        [0.0, 0.5 * m.fan_max_w, m.fan_max_w], atol=1e-12,
    )


def test_thermal_step_matches_ode_integration():
    # dtheta/dt = (R * P - (theta - ambient)) / tau, integrated numerically
    m = DEFAULT_MODEL
    ambient, theta0, p_loss, dt = 22.0, 30.0, 900.0, 250.0
    sol = solve_ivp(lambda _t, y: (m.r_th_k_per_w * p_loss - (y - ambient)) / m.tau_th_s,
                    (0.0, dt), [theta0], rtol=1e-10, atol=1e-10)
    assert theta_step(theta0, p_loss, ambient, dt, m) == pytest.approx(sol.y[0, -1], abs=1e-6)


def test_loss_is_electrical_minus_mechanical_without_fan():
    m = DEFAULT_MODEL
    n, t, theta = 800.0, 40.0, 75.0
    expected = true_p_elec_w(n, t, theta, m) - n * np.pi / 30.0 * t - fan_power_w(theta, m)
    assert loss_w(n, t, theta, m) == pytest.approx(expected, rel=1e-12)


def test_calibration_returns_the_target_fit():
    # a campaign whose evaluation adds a non-quadratic |n| term: the calibrated core must
    # make the OLS fit land on the target to the calibration's tolerance (1e-9 relative)
    rng = np.random.default_rng(3)
    n = rng.uniform(-3000, 1500, 400)
    t = rng.uniform(0, 78, 400)

    def evaluate(model: LossModel):
        return n, t, true_p_elec_w(n, t, model=model)

    model = calibrate_core(evaluate, DEFAULT_MODEL)
    coef, _ = fit_quadratic(*evaluate(model))
    np.testing.assert_allclose(coef, PAPER_QUADRATIC, rtol=1e-8)
    assert model.c0_w < PAPER_QUADRATIC[0]  # the extra losses took part of the constant


def test_from_dict_round_trip_and_rejects_unknown_keys():
    d = DEFAULT_MODEL.to_dict()
    assert LossModel.from_dict(d) == DEFAULT_MODEL
    with pytest.raises(KeyError):
        LossModel.from_dict({**d, "bogus": 1.0})
    d.pop("tau_th_s")
    with pytest.raises(KeyError):
        LossModel.from_dict(d)
