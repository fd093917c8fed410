"""Bounds of different parts that cannot hold together are refused before any solve,
naming both keys (optimize/system/contradictions.py); bounds that cross in the NLP are
named with their inputs instead of the solver's assertion (optimize/problem/ocp.py); an
optimum on the line-angle bound is listed in ``active_bounds``."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from system_fixtures import system_for

from drivebench.cli import main
from kernel.errors import InputError
from optimize.paper_model import paper_model
from optimize.problem.options import Discretization, OcpOptions
from optimize.system.contradictions import check_contradictions
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import system_from_dict

ROOT = Path(__file__).resolve().parents[1]
HIGHWIND = tomllib.loads(shipped_system_path().read_text())


def _system(**changes):
    """highwind.toml with ``section__key=value`` changes (None removes the key)."""
    data = json.loads(json.dumps(HIGHWIND))
    for name, value in changes.items():
        section, key = name.split("__")
        if value is None:
            data[section].pop(key, None)
        else:
            data[section][key] = value
    return system_from_dict(data, "my_kite.toml")


def _check(system, model=None, kinds=("elec-lim",), model_path=None):
    model = model or paper_model()
    rating = drive_in_force(system, drive_model=model)[0]
    check_contradictions(system.in_force(rating), model, kinds, model_path)


def _thermal_model(tmp_path, r_th):
    data = json.loads((ROOT / "optimize/data/paper_drive_model.json").read_text())
    data["schema_version"] = 3
    data["thermal"] = {"nodes": 1, "r_th_k_per_w": r_th, "tau_th_s": 900.0,
                       "c_th_j_per_k": 900.0 / r_th, "copper_temp_coeff_per_k": 0.00393,
                       "theta_ref_c": 20.0, "ambient_c": 25.0}
    path = tmp_path / f"thermal_{r_th:g}.json"
    path.write_text(json.dumps(data))
    return path


def test_the_shipped_systems_hold_together():
    for name in ("highwind", "highwind_drivetrain", "ap2", "megawes"):
        from optimize.system.system_file import load_system

        system = load_system(shipped_system_path(name))
        drive, _ = drive_in_force(system)
        check_contradictions(system.in_force(drive), drive.power_model,
                             ("elec-lim", "mech-free"))


def test_a_tension_floor_the_drive_cannot_pull_is_refused_naming_both_keys():
    # the case: 5000 N with the 78 N m drive on a 0.1 m drum (it pulls 780 N);
    # was 27 s of IPOPT ending in "Assertion lb <= ub failed"
    with pytest.raises(InputError) as err:
        _check(_system(bounds__min_tension_n=5000.0))
    text = err.value.describe()
    assert text.startswith("my_kite.toml: [bounds] min_tension_n: the tension floor 5000 N")
    assert "[drive] max_torque_nm 78 N m, which pulls at most 780 N" in text
    # the kinds without drive limits can hold it: not refused for them alone
    _check(_system(bounds__min_tension_n=5000.0), kinds=("mech-free", "elec-free"))
    # at the edge it holds; a larger drum or a gear ratio changes what the drive pulls
    _check(_system(bounds__min_tension_n=779.0))
    with pytest.raises(InputError, match="pulls at most 390 N"):
        _check(_system(bounds__min_tension_n=500.0, winch__drum_radius_m=0.2))
    _check(_system(bounds__min_tension_n=1500.0, winch__gear_ratio=2.0))


def test_a_tension_floor_above_the_continuous_rating_is_refused():
    # the RMS torque over the cycle is at least the floor's torque
    with pytest.raises(InputError) as err:
        _check(_system(bounds__min_tension_n=600.0, drive__max_torque_nm=390.0,
                       drive__continuous_torque_nm=50.0, drive__scaling="none"))
    assert "continuous (RMS) torque rating [drive] continuous_torque_nm 50 N m" in str(err.value)


@pytest.mark.parametrize("base, refused", [(1e-3, True), (400.0, True), (600.0, False),
                                           (1000.0, False), (5000.0, False)])
def test_a_base_speed_that_leaves_no_envelope_is_refused(base, refused):
    # 78 N m x base speed against the nominal 8200 W (at half of it: 502 rpm); was a cycle
    # drawing +290 W at 1e-3 rpm
    system = _system(drive__base_speed_rpm=base)
    if not refused:
        _check(system)
        return
    with pytest.raises(InputError) as err:
        _check(system)
    assert "[drive] base_speed_rpm: the torque-speed envelope leaves" in str(err.value)
    assert "nominal_power_w 8200 W" in str(err.value) and "about 1004 rpm" in str(err.value)


@pytest.mark.parametrize("speeds, torques, refused", [
    ([0.0, 1000.0, 1001.0], [78.0, 78.0, 1.0], "too steep"),
    ([0.0, 1000.0, 1010.0], [78.0, 78.0, 20.0], "too steep"),
    ([0.0, 1000.0, 1500.0], [78.0, 78.0, 50.0], None),  # a datasheet's field weakening
    ([0.0, 100.0, 1500.0], [78.0, 5.0, 5.0], "leaves the drive at most"),
])
def test_an_envelope_table_that_leaves_no_envelope_is_refused(speeds, torques, refused):
    system = _system(drive__envelope_speed_rpm=speeds, drive__envelope_torque_nm=torques)
    if refused is None:
        _check(system)
        return
    with pytest.raises(InputError) as err:
        _check(system)
    assert "[drive] envelope_speed_rpm, envelope_torque_nm" in str(err.value)
    assert refused in str(err.value)


def test_a_thermal_block_absurd_for_the_drive_is_refused(tmp_path):
    # r_th 1e6 K/W: the winding at 1e9 degC at the continuous rating; was 269 s of IPOPT
    # to Maximum_Iterations_Exceeded without naming the block
    system = _system(drive__max_winding_temperature_c=120.0)
    bad = _thermal_model(tmp_path, 1e6)
    from fitting.model_file import load_power_model

    with pytest.raises(InputError) as err:
        _check(system, load_power_model(bad), model_path=bad)
    text = err.value.describe()
    assert text.startswith(f"{bad}: field 'thermal' (r_th 1e+06 K/W)")
    assert "max_winding_temperature_c 120 degC" in text and "of the order of 0.07" in text
    good = _thermal_model(tmp_path, 0.05)
    _check(system, load_power_model(good), model_path=good)
    _check(system, load_power_model(bad), kinds=("mech-free",))  # no drive limits flown


@pytest.mark.parametrize("edit, words", [
    ({"bounds": {"min_tension_n": 5000.0}}, "[bounds] min_tension_n"),
    ({"drive": {"base_speed_rpm": 0.001}}, "[drive] base_speed_rpm"),
    ({"drive": {"envelope_speed_rpm": [0.0, 1000.0, 1001.0],
                "envelope_torque_nm": [78.0, 78.0, 1.0]}}, "too steep"),
])
def test_bench_optimize_refuses_contradictions_before_any_solve(tmp_path, capsys, edit, words):
    text = shipped_system_path().read_text()
    for section, values in edit.items():
        lines = "".join(f"{k} = {json.dumps(v)}\n" for k, v in values.items())
        text = text.replace(f"[{section}]\n", f"[{section}]\n{lines}", 1)
    path = tmp_path / "contra.toml"
    path.write_text(text)
    assert main(["optimize", "--system", str(path), "--wind-grid", "7", "--scenarios",
                 "elec-lim", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "contra.toml" in err and words in err and "Traceback" not in err, err
    assert not (tmp_path / "o").exists()


def test_crossed_bounds_are_named_with_their_inputs_not_an_assertion():
    # bounds that reach the NLP crossed (here: the tension floor's torque row against the
    # torque limit, past the check above) are refused when the solve asks for them
    from optimize.model.kite_model import kite_dae
    from optimize.problem.ocp import build_ocp

    options = OcpOptions(Discretization(n_intervals=3, degree=2))
    ocp = build_ocp(kite_dae(), paper_model(), options,
                    system=system_for(bounds={"min_tension_n": 5000.0}))
    ocp.bounds(False, True, None)  # no drive limits: nothing crosses
    with pytest.raises(ValueError) as err:
        ocp.bounds(True, True, None)
    assert "torque ([drive] max_torque_nm against [bounds] min_tension_n" in str(err.value)


def test_an_optimum_on_the_line_angle_bound_is_listed(coarse_ocp, coarse_elec_lim):
    # the paper's optimum sits on its 65 deg bound; held to 20 deg it sits on that one
    from optimize.model.kite_model import kite_dae
    from optimize.problem.ocp import build_ocp
    from optimize.problem.scenario import Scenario
    from optimize.solve.solve import solve

    assert coarse_elec_lim.success
    assert coarse_elec_lim.trajectory["line_angle_deg"].max() == pytest.approx(65.0, abs=1e-3)
    assert "line_angle_limit" in coarse_elec_lim.active_bounds
    res = solve(build_ocp(kite_dae(), paper_model(), coarse_ocp.options,
                          system=system_for(bounds={"max_line_angle_deg": 20.0})),
                Scenario(7.0, "electrical", True), coarse_elec_lim.warm)
    assert res.success, res.status
    assert res.trajectory["line_angle_deg"].max() == pytest.approx(20.0, abs=1e-3)
    assert "line_angle_limit" in res.active_bounds


@pytest.mark.parametrize("clearance_m", [502.0, 1000.0])
def test_a_ground_clearance_above_the_longest_tether_is_refused(clearance_m):
    # the kite flies at most winch height (2 m) + tether_length_max_m (500 m) high; was a
    # 16 s solve that ended FAILED without naming either key
    with pytest.raises(InputError) as err:
        _check(_system(bounds__min_ground_clearance_m=clearance_m))
    text = err.value.describe()
    assert "[bounds] min_ground_clearance_m" in text and "tether_length_max_m 500 m" in text
    assert "winch_height_m 2 m" in text and "at most 502 m high" in text
    _check(_system(bounds__min_ground_clearance_m=400.0))  # within reach: no contradiction
