"""The bounds and model keys of awebox's AP2 settings (issue 39): read, refused when wrong,
flown.

Truths: awebox's AP2 force coefficients in body axes (awebox/awebox 03adf950,
``awebox/opts/kite_data/ampyx_data.py``, Malz et al. 2019) turned into lift and drag by
the exact rotation ``CL = CX sin a - CZ cos a``, ``CD = -CX cos a - CZ sin a`` against the
shipped file's polynomials; for the bounds, the optimum's own trajectory against the
stated limits.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from kernel.errors import InputError
from optimize.model.aero import at_alpha, force_coefficients, moment_coefficients
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system, system_from_dict


def _data(name: str = "highwind", **changes) -> dict:
    data = tomllib.loads(shipped_system_path(name).read_text())
    for key, value in changes.items():
        section, name = key.split("__")
        if value is None:
            data[section].pop(name, None)
        else:
            data[section][name] = value
    return data


def test_ap2_lift_and_drag_are_awebox_body_axis_coefficients():
    aero = load_system(shipped_system_path("ap2")).aero
    alpha = np.radians(np.linspace(aero.alpha_min_deg, aero.alpha_max_deg, 31))
    q_hat, elev = 0.02, np.radians(3.0)

    def poly(*c):
        return np.polynomial.polynomial.polyval(alpha, c)

    # ampyx_data.py: CX '0', 'alpha', 'q', 'deltae'; CZ likewise
    cx = poly(-0.0293) + alpha * poly(0.4784, 2.5549) + q_hat * poly(-0.6029, 4.4124) \
        + elev * poly(-0.0106, 0.1115)
    cz = poly(-0.5526) + alpha * poly(-5.0676, 5.7736) + q_hat * poly(-7.5560, 0.1251, 6.1486) \
        + elev * poly(-0.315, -0.0013, 0.2923)
    cl, cd, _ = force_coefficients(alpha, 0.0, (0.0, elev, 0.0), aero.coefficients,
                                   (0.0, q_hat, 0.0))
    np.testing.assert_allclose(cl, cx * np.sin(alpha) - cz * np.cos(alpha), atol=2e-6)
    np.testing.assert_allclose(cd, -cx * np.cos(alpha) - cz * np.sin(alpha), atol=2e-6)
    # moments: Cm '0', 'alpha', 'q', 'deltae' as awebox sums them
    _, cm, _ = moment_coefficients(alpha, 0.0, (0.0, q_hat, 0.0), (0.0, elev, 0.0),
                                   aero.coefficients)
    np.testing.assert_allclose(cm, -0.0307 - 0.6027 * alpha + q_hat * poly(-11.3022, -0.0026,
                               5.2885) + elev * poly(-1.0427, -0.0061, 0.9974), rtol=1e-12)


def test_a_polynomial_of_one_term_is_the_number():
    assert at_alpha((0.7,), np.linspace(-0.1, 0.1, 5)) == 0.7
    np.testing.assert_allclose(at_alpha((1.0, -2.0, 3.0), np.array([0.0, 0.5])), [1.0, 0.75])


@pytest.mark.parametrize("key, value, words", [
    ("winch__max_reel_out_speed_m_s", 0.0, "[winch] max_reel_out_speed_m_s"),
    ("winch__max_reel_in_speed_m_s", -3.0, "[winch] max_reel_in_speed_m_s"),
    ("bounds__max_body_rate_deg_s", 0.0, "[bounds] max_body_rate_deg_s"),
    ("bounds__min_tension_n", -1.0, "[bounds] min_tension_n"),
    ("wind__atmosphere", "standard", "[wind] atmosphere"),
    ("tether__drag_elements", 0, "[tether] drag_elements"),
    ("tether__drag_elements", 2.5, "[tether] drag_elements"),
    ("tether__mass_kg_m", -0.01, "[tether] mass_kg_m"),
    ("tether__density_kg_m3", 20.0, "[tether] density_kg_m3"),
    ("aero__cl0", [], "[aero] cl0"),
    ("aero__cn_rud", [0.1, "x"], "[aero] cn_rud"),
    ("aero__cy_p", True, "[aero] cy_p"),
    ("bounds__elevator_max_deg", 0.0, "[bounds] elevator_max_deg"),
    ("bounds__rudder_max_deg", 95.0, "[bounds] rudder_max_deg"),
    ("bounds__surface_max_deg", 90.0, "[bounds] surface_max_deg"),
])
def test_a_bad_value_names_the_key(key, value, words):
    with pytest.raises(InputError) as err:
        system_from_dict(_data(**{key: value}), "my_kite.toml")
    assert words in str(err.value) and "my_kite.toml" in str(err.value)


def test_crossed_keys_name_the_key():
    with pytest.raises(InputError, match=r"\[tether\] density_kg_m3: given with mass_kg_m"):
        system_from_dict(_data(tether__mass_kg_m=0.01, tether__density_kg_m3=970.0), "x.toml")
    with pytest.raises(InputError, match=r"\[bounds\] min_tension_n: 1800 N is not below"):
        system_from_dict(_data("ap2", bounds__min_tension_n=1800.0), "x.toml")
    with pytest.raises(InputError, match=r"\[aero\] cl_alpha: the lift slope"):
        system_from_dict(_data(aero__cl0=[0.2, 0.5, -40.0]), "x.toml")


def test_the_cli_refuses_a_bad_key_with_exit_2(tmp_path, capsys):
    from drivebench.cli import main

    text = shipped_system_path("ap2").read_text().replace(
        "max_body_rate_deg_s = 50.0", "max_body_rate_deg_s = -50.0")
    path = tmp_path / "ap2.toml"
    path.write_text(text)
    assert main(["optimize", "--system", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "[bounds] max_body_rate_deg_s" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_the_tether_keys_reach_the_model():
    ap2 = load_system(shipped_system_path("ap2"))
    tether = ap2.tether_model()
    assert (tether.mass_kg_m, tether.drag_elements) == (0.0046, 5)
    assert ap2.kite_params().tether_cd_per_m == 0.0  # the elements replace the lumped drag
    assert ap2.wind_model().temperature_lapse_k_m == 0.0065
    dense = system_from_dict(_data(tether__density_kg_m3=970.0), "x.toml")
    assert dense.tether_model().mass_kg_m == pytest.approx(970.0 * np.pi * 0.001**2 / 4)
    plain = load_system()
    assert plain.tether_model().mass_kg_m == 0.0 and plain.tether_model().drag_elements == 0


def test_each_surface_has_its_own_bound():
    assert load_system(shipped_system_path("ap2")).bounds.surface_bounds_deg() == (20.0, 30.0, 30.0)
    assert load_system().bounds.surface_bounds_deg() == (10.0, 10.0, 10.0)


def test_reel_speed_body_rate_tension_and_surface_bounds_hold_and_are_reported(
        stored_guess_solve):
    """The paper's kite, elec-lim at 7 m/s from the stored guess's optimum (solved on the
    shipped system: the guess is not used for another system file), with every new bound
    inside the optimum's range without them (reel-out 5.0, reel-in 12.8 m/s, body rates
    130 deg/s; tension from 52 N, 102 N with the others in force; elevator 6.4 deg): the
    optimum keeps each, sits on each, reports each. The rudder, on its 10 deg bound
    without them, gets 12 deg of its own."""
    system = system_from_dict(_data(
        winch__max_reel_out_speed_m_s=4.0, winch__max_reel_in_speed_m_s=11.0,
        bounds__max_body_rate_deg_s=120.0, bounds__min_tension_n=250.0,
        bounds__elevator_max_deg=5.0, bounds__rudder_max_deg=12.0), "bounds.toml")
    model = paper_model()
    flown = system.in_force(drive_in_force(system, drive_model=model)[0])
    res = solve(build_ocp(kite_dae(*system.model_params()), model, OcpOptions(), system=flown),
                Scenario.of_kind("elec-lim", 7.0), stored_guess_solve.warm)
    assert res.success, res.status
    traj, tol = res.trajectory, 1e-6
    rates = np.degrees(traj[["omega_x_rad_s", "omega_y_rad_s", "omega_z_rad_s"]].abs())
    assert traj.dl_m_s.max() <= 4.0 + tol and traj.dl_m_s.min() >= -11.0 - tol
    assert rates.to_numpy().max() <= 120.0 + tol
    assert traj.tension_n.min() >= 250.0 - 1e-3
    surfaces = np.degrees(traj[["aileron_rad", "elevator_rad", "rudder_rad"]].abs().max())
    assert (surfaces.to_numpy() <= np.array([10.0, 5.0, 12.0]) + tol).all(), surfaces
    assert surfaces["rudder_rad"] > 10.0 + 1e-3, surfaces
    assert {"reel_out_speed_limit", "reel_in_speed_limit", "body_rate_limit",
            "tension_min", "surface_limit"} <= set(res.active_bounds), res.active_bounds


def test_the_header_states_the_tether_and_air_and_the_new_limits():
    ap2 = load_system(shipped_system_path("ap2"))
    assert ap2.tether_air_line() == (
        "tether: 0.0046 kg/m (a rod with its weight and mass flow), drag over 5 elements "
        "with their own apparent wind; air: ISA from 1.225 kg/m^3 at the ground")
    assert "tension >= 50 N" in ap2.kite_limits_line()
    assert "body rates within 50 deg/s" in ap2.kite_limits_line()
    assert "reel-out speed <= 20 m/s (all kinds), reel-in speed <= 15 m/s" in \
        ap2.drivetrain_line()
    assert load_system().tether_air_line().startswith("tether: massless, drag lumped")
