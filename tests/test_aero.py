"""Aerodynamic model against hand calculations (docs/paper_figures.md §2)."""

import math

import casadi as ca
import numpy as np
import pytest

from optimize.model.aero import aero_forces_moments, wind_speed
from optimize.model.params import AeroCoefficients, KiteParams, WindModel

KITE = KiteParams()
COEF = AeroCoefficients()


def _eval(dcm, v_air, omega, surf, length):
    out = aero_forces_moments(ca.DM(dcm), ca.DM(v_air), ca.DM(omega), ca.DM(surf), length,
                              KITE, COEF)
    return (np.asarray(out.force_n).ravel(), np.asarray(out.moment_nm).ravel(),
            float(out.alpha_rad), float(out.beta_rad), float(out.cl), float(out.cd))


def test_level_flight_hand_calculation():
    # Body = world axes, air-relative velocity 20 m/s forward and 1 m/s "down" in body z:
    # alpha = atan(1/20), beta = 0, no rates, no surfaces, 100 m of tether.
    v = np.array([20.0, 0.0, 1.0])
    force, moment, alpha, beta, cl, cd = _eval(np.eye(3), v, np.zeros(3), np.zeros(3), 100.0)
    a = math.atan2(1.0, 20.0)
    assert alpha == pytest.approx(a, rel=1e-12)
    assert beta == pytest.approx(0.0, abs=1e-15)
    cl_hand = 0.203530 + 5.786876 * a
    cd_hand = 0.008767 + 0.018751 * a + 1.529989 * a**2 + 0.25 * 100 * 0.001 / 0.684
    q_s = 0.5 * 1.23 * 0.684 * (20.0**2 + 1.0)
    speed = math.sqrt(401.0)
    # lift along e_y x v = (v_z, 0, -v_x)/|v|, drag against v (all in N)
    lift = q_s * cl_hand * np.array([1.0, 0.0, -20.0]) / speed
    drag = -q_s * cd_hand * v / speed
    # exact up to float rounding: same formulas evaluated in a different order
    np.testing.assert_allclose(force, lift + drag, rtol=1e-12, atol=1e-9)
    assert cl == pytest.approx(cl_hand, rel=1e-12)
    assert cd == pytest.approx(cd_hand, rel=1e-12)
    # moments: only C_m = cm0 + cm_alpha alpha is non-zero (beta, rates, surfaces zero)
    cm = 0.028980 - 0.450643 * a
    np.testing.assert_allclose(moment, [0.0, q_s * 0.2512 * cm, 0.0], rtol=1e-12, atol=1e-12)


def test_surfaces_use_per_degree_derivatives():
    # 1 degree of elevator changes C_L by -0.0105 and C_m by 0.0352 (docs/paper_figures.md §2)
    v = np.array([25.0, 0.0, 0.0])
    one_deg = math.radians(1.0)
    _, m0, _, _, cl0, _ = _eval(np.eye(3), v, np.zeros(3), np.zeros(3), 50.0)
    _, m1, _, _, cl1, _ = _eval(np.eye(3), v, np.zeros(3), [0.0, one_deg, 0.0], 50.0)
    assert cl1 - cl0 == pytest.approx(-0.0105, rel=1e-9)
    q_s_c = 0.5 * 1.23 * 0.684 * 625.0 * 0.2512
    assert (m1[1] - m0[1]) / q_s_c == pytest.approx(0.0352, rel=1e-9)


def test_general_state_against_independent_numpy():
    # A rotated body with sideslip, rates and deflections, checked against a numpy
    # re-implementation in wind axes: drag along -v_hat, lift along e_y x v_hat
    # normalised, side force along v_hat x (e_y x v_hat), moments from REFERENCE §2.
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    dcm = q * np.sign(np.linalg.det(q))
    v_body = np.array([22.0, 2.0, 1.5])
    v = dcm @ v_body
    omega = np.array([0.3, -0.2, 0.5])
    surf = np.radians([3.0, -2.0, 4.0])
    length = 120.0
    force, moment, alpha, beta, _, _ = _eval(dcm, v, omega, surf, length)

    speed = np.linalg.norm(v_body)
    a, b = math.atan2(v_body[2], v_body[0]), math.asin(v_body[1] / speed)
    assert alpha == pytest.approx(a) and beta == pytest.approx(b)
    ail, elev, rud = surf
    deg = 180 / math.pi
    cl = 0.203530 + 5.786876 * a - 0.0105 * deg * elev
    cd = (0.008767 + 0.018751 * a + 1.529989 * a**2 - 0.16247 * b**2 + 4.19816e-05 * elev**2
          - 9.79647e-05 * a * elev + 4.52856e-05 * elev + 5.60583e-05 * ail**2
          - 6.73139e-06 * b * ail + 2.03105e-05 * rud**2 + 5.55453e-05 * b * rud
          + 0.25 * length * 0.001 / 0.684)
    cy = -0.239789 * b + 0.0035 * deg * rud
    q_s = 0.5 * 1.23 * 0.684 * speed**2
    v_hat = v / speed
    e_y = dcm[:, 1]
    lift_dir = np.cross(e_y, v_hat)  # not unit length when beta != 0 (as in the reference)
    side_dir = np.cross(v_hat, lift_dir)
    expected = q_s * (cl * lift_dir - cd * v_hat + cy * side_dir)
    np.testing.assert_allclose(force, expected, rtol=1e-10)
    p_, q_, r_ = omega * np.array([2.904, 0.2512, 2.904]) / (2 * speed)
    c_roll = -0.576 * p_ + 0.0707 * r_ - 0.051808 * b - 0.208344 * a * b + 0.0073 * deg * ail
    c_pitch = 0.028980 - 15.5 * q_ - 0.450643 * a + 0.0352 * deg * elev
    c_yaw = -0.036 * p_ - 0.0667 * r_ + 0.037183 * b - 0.028933 * a * b + 0.001176 * deg * rud
    np.testing.assert_allclose(
        moment, q_s * np.array([2.904 * c_roll, 0.2512 * c_pitch, 2.904 * c_yaw]), rtol=1e-10
    )


def test_side_force_opposes_sideslip():
    # the kite slides to the right (beta > 0, no rudder): the force pushes it left (-y)
    force, _, _, beta, _, _ = _eval(np.eye(3), [20.0, 2.0, 0.0], np.zeros(3), np.zeros(3), 1.0)
    assert beta > 0 and force[1] < 0


def test_log_wind_shear_hand_values():
    wind = WindModel()
    # w(h) = w_ref ln((h + 0.1)/0.1) / ln(100/0.1): w_ref at h = 99.9 m;
    # w(10 m) = ln(101)/ln(1000) w_ref (rounding-level tolerance: same formula)
    assert float(wind_speed(99.9, 7.0, wind)) == pytest.approx(7.0, rel=1e-12)
    assert float(wind_speed(10.0, 7.0, wind)) == pytest.approx(
        7.0 * math.log(101.0) / math.log(1000.0), rel=1e-12
    )


def test_from_dict_rejects_unknown_and_missing_keys():
    good = {"reference_altitude_m": 100.0, "roughness_length_m": 0.1, "origin_altitude_m": 2.0,
            "power_law_exponent": 0.0, "temperature_lapse_k_m": 0.0}
    assert WindModel.from_dict(good) == WindModel()
    with pytest.raises(ValueError, match="unknown keys"):
        WindModel.from_dict({**good, "gust": 1.0})
    with pytest.raises(ValueError, match="missing keys"):
        WindModel.from_dict({"reference_altitude_m": 100.0})
    with pytest.raises(ValueError, match="must be a number"):
        KiteParams.from_dict({**{f: 1.0 for f in KiteParams.__dataclass_fields__},
                              "mass_kg": "heavy"})
