"""The drivetrain in the cycle: shaft torque = tether torque + acceleration torque, the
kinetic energy's zero cycle integral, the reel-acceleration limit and the torque-speed
envelope, from the system file to the optimum.

Truths: closed forms of a prescribed reel motion ``dl = A sin(W t)`` (the kinetic energy
``J w^2 / 2`` is periodic, so its rate integrates to zero; the acceleration torque is
``-J i A W cos(W t) / r``); the envelope's own definition recomputed from the trajectory.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from system_fixtures import system_for

from kernel.errors import InputError
from kernel.units import RPM_PER_RAD_S
from optimize.model.drivetrain import Drivetrain, mechanical_power_w
from optimize.model.envelope import EnvelopeTable
from optimize.model.kite_model import ALGEBRAIC, STATES, kite_dae
from optimize.model.params import KiteParams
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.solve.starts.cold import start
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import system_from_dict

R_M, GEAR, J_DRUM, J_ROTOR = 0.1, 3.0, 0.45, 0.01
AMPLITUDE_M_S, RATE_RAD_S = 4.0, 2 * np.pi / 5.0


def _prescribed(n: int = 400):
    t = np.arange(n) * (2 * np.pi / RATE_RAD_S) / n  # one period, periodic grid
    return t, AMPLITUDE_M_S * np.sin(RATE_RAD_S * t), AMPLITUDE_M_S * RATE_RAD_S * np.cos(
        RATE_RAD_S * t)


def test_kinetic_energy_integrates_to_zero_over_a_cycle():
    dt = Drivetrain(R_M, GEAR, J_DRUM, J_ROTOR)
    assert dt.inertia_kg_m2 == pytest.approx(J_ROTOR + J_DRUM / GEAR**2, rel=1e-15)
    t, dl, ddl = _prescribed()
    tension = 800.0 + 300.0 * np.cos(RATE_RAD_S * t + 0.3)
    kinetic = dt.shaft_power_w(tension, dl, ddl) - mechanical_power_w(tension, dl)
    # closed form of J w dw/dt with w = -i dl / r
    closed = dt.inertia_kg_m2 * (GEAR / R_M) ** 2 * dl * ddl
    # (the difference of two powers of kW: to rounding of those)
    assert np.allclose(kinetic, closed, rtol=0, atol=1e-12 * np.abs(tension * dl).max())
    # the periodic trapezoid is exact for the trigonometric integrand
    assert abs(kinetic.sum()) <= 1e-9 * np.abs(kinetic).sum()


def test_power_model_is_evaluated_at_the_shaft_torque():
    kite = KiteParams(r_winch_m=R_M, gear_ratio=GEAR, drum_inertia_kg_m2=J_DRUM,
                      rotor_inertia_kg_m2=J_ROTOR)
    ocp = build_ocp(kite_dae(kite), paper_model(), OcpOptions(Discretization(4, 2)),
        system=system_for())
    t, dl, ddl = _prescribed(16)
    x = np.zeros((STATES.size, t.size))
    x[STATES.index("l_m")], x[STATES.index("dl_m_s")], x[STATES.index("ddl_m_s2")] = 200, dl, ddl
    x[STATES.index("r_x_m")] = 200.0
    z = np.zeros((ALGEBRAIC.size, t.size))
    z[ALGEBRAIC.index("nu_n_per_m")] = 4.0  # 800 N on 200 m
    out = ocp.formulation.trajectory_outputs(x, np.zeros((4, t.size)), z, 7.0)
    tether = 800.0 * R_M / GEAR
    shaft = tether - (J_ROTOR + J_DRUM / GEAR**2) * GEAR * ddl / R_M
    assert np.allclose(out["tether_torque_nm"], tether, rtol=1e-12)
    assert np.allclose(out["torque_nm"], shaft, rtol=1e-12)
    speed = -dl / R_M * GEAR * RPM_PER_RAD_S
    assert np.allclose(out["p_elec_w"], paper_model().p_elec_w(speed, shaft), rtol=1e-12)
    assert np.allclose(out["p_mech_w"], shaft * speed / RPM_PER_RAD_S, rtol=1e-10, atol=1e-9)


def test_a_massless_drivetrain_is_the_massless_ocp():
    # inertia 0: the shaft torque is the tether torque, one torque row bounded above only,
    # and no tether-force row (the OCP before the drivetrain; the sweep's optima against
    # it: benchmarks/drivetrain_effect.py, paper-0)
    massless = KiteParams(drum_inertia_kg_m2=0.0, rotor_inertia_kg_m2=0.0)
    ocp = build_ocp(kite_dae(massless), paper_model(),
                    OcpOptions(Discretization(4, 2)),
                    system=system_for(tether={"max_force_n": 2000.0}))
    lay, tr = ocp.layout, ocp.transcription
    assert "tether_force" not in lay.rows
    rows = lay.rows_of("torque")
    assert np.all(np.isneginf(tr.limited[2][rows])) and np.all(np.isneginf(tr.lbg[rows]))
    heavy = build_ocp(kite_dae(KiteParams(drum_inertia_kg_m2=0.1)), paper_model(),
                      OcpOptions(Discretization(4, 2)),
                    system=system_for(tether={"max_force_n": 2000.0}))
    rows = heavy.layout.rows_of("torque")
    assert "tether_force" in heavy.layout.rows
    assert np.allclose(heavy.transcription.limited[2][rows] * heavy.scales.torque_nm, -78.0)


def test_smooth_table_envelope_stays_below_the_table():
    table = EnvelopeTable((0.0, 1000.0, 1500.0, 3000.0), (78.0, 78.0, 52.0, 26.0))
    speed = np.linspace(-3500, 3500, 1401)
    smooth, exact = table.smooth_values_nm(speed), table.torque_nm(speed)
    assert np.all(smooth <= exact + 1e-12)
    # within w (ln 2 sum |slope changes| + max |slope|) of the table (its documented bound)
    width = 0.005 * 3000.0
    slopes = np.array([0.0, -26 / 500, -26 / 1500, 0.0])
    bound = width * (np.log(2) * np.abs(np.diff(slopes)).sum() + np.abs(slopes).max())
    assert np.max(exact - smooth) <= bound


def _system(**winch_drive) -> dict:
    import tomllib

    data = tomllib.loads(shipped_system_path("highwind").read_text())
    for key, value in winch_drive.items():
        section, name = key.split("__")
        data[section][name] = value
    return data


@pytest.mark.parametrize("key, value, words", [
    ("winch__drum_inertia_kg_m2", -0.1, "[winch] drum_inertia_kg_m2"),
    ("drive__rotor_inertia_kg_m2", -1e-3, "[drive] rotor_inertia_kg_m2"),
    ("winch__max_reel_acceleration_m_s2", 0.0, "[winch] max_reel_acceleration_m_s2"),
    ("winch__max_reel_acceleration_m_s2", -5.0, "[winch] max_reel_acceleration_m_s2"),
    ("drive__base_speed_rpm", 0.0, "[drive] base_speed_rpm"),
])
def test_bad_drivetrain_keys_name_the_key(key, value, words):
    with pytest.raises(InputError) as err:
        system_from_dict(_system(**{key: value}), "my_kite.toml")
    assert words in str(err.value) and "my_kite.toml" in str(err.value)


@pytest.mark.parametrize("speeds, torques, words", [
    ([0, 1500, 1000], [78, 60, 50], "envelope_speed_rpm"),
    ([100, 1000, 1500], [78, 60, 50], "envelope_speed_rpm"),
    ([0, 1000, 1500], [78, 60, 70], "envelope_torque_nm"),
    ([0, 1000, 1500], [78, 60], "envelope_torque_nm"),
])
def test_an_envelope_table_that_is_not_monotone_is_refused(speeds, torques, words):
    data = _system(drive__envelope_speed_rpm=speeds, drive__envelope_torque_nm=torques)
    with pytest.raises(InputError) as err:
        system_from_dict(data, "my_kite.toml")
    assert f"[drive] {words}" in str(err.value)


def test_cli_refuses_a_negative_inertia_before_any_solve(tmp_path):
    from drivebench.cli import main

    text = shipped_system_path().read_text().replace(
        "[winch]\n", "[winch]\ndrum_inertia_kg_m2 = -0.2\n", 1)
    path = tmp_path / "neg.toml"
    path.write_text(text)
    assert main(["optimize", "--system", str(path), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


@pytest.fixture(scope="module")
def heavy_cycle():
    """elec-lim at 10 m/s of the paper's kite with a drivetrain: inertia, an acceleration
    limit and a base speed below the top speed (a cold start at N = 20)."""
    data = _system(winch__drum_inertia_kg_m2=0.04, drive__rotor_inertia_kg_m2=0.057,
                   winch__max_reel_acceleration_m_s2=30.0, drive__base_speed_rpm=1000.0)
    system = system_from_dict(data, "heavy.toml")
    model = paper_model()
    options = OcpOptions(Discretization(20, 3), solver=SolverOptions(stored_guess=False))
    ocp = build_ocp(kite_dae(*system.model_params()), model, options,
                    system=system.in_force(drive_in_force(system, drive_model=model)[0]))
    return system, ocp, solve_by_homotopy(ocp, Scenario(10.0, "electrical", True))


def test_the_optimal_cycle_stays_within_the_drive(heavy_cycle):
    # recomputed from the trajectory by the formulas of the module docstring, not the
    # OCP's rows: shaft torque = l nu r / i - J i l'' / r, at most 78 N m and at most
    # 78 N m * 1000 rpm / |n| above the base speed, |l''| <= 30 m/s^2, at every point
    system, ocp, res = heavy_cycle
    assert res.success, res.status
    t = res.trajectory
    j = 0.04 + 0.057  # gear ratio 1
    shaft = t["l_m"] * t["nu_n_per_m"] * 0.1 - j * t["ddl_m_s2"] / 0.1
    assert np.allclose(t["torque_nm"], shaft, rtol=1e-9, atol=1e-9)
    speed = np.abs(t["dl_m_s"] / 0.1 * RPM_PER_RAD_S)
    envelope = np.minimum(78.0, 78.0 * 1000.0 / speed)
    tol = 1e-6 * 78.0  # IPOPT's constraint tolerance on the scaled rows
    assert np.all(np.abs(shaft) <= envelope + tol)
    assert t["ddl_m_s2"].abs().max() <= 30.0 + 1e-6
    assert speed.max() > 1000.0  # the cycle does run above the base speed
    assert {"torque_limit", "reel_acceleration_limit"} <= set(res.active_bounds)
    # the envelope is active only where it, not the torque limit, is the bound: above the
    # base speed (this cycle reels in there, far below it)
    above = speed > 1000.0 / (1.0 - 1e-3)
    on_envelope = bool(np.any(np.abs(np.abs(shaft[above]) / envelope[above] - 1.0) <= 1e-3))
    assert ("envelope_limit" in res.active_bounds) == on_envelope
    # the kinetic energy's share of the shaft power averages to zero over the cycle
    kinetic = t["p_mech_w"] - (-t["l_m"] * t["nu_n_per_m"] * t["dl_m_s"])
    assert abs((t["weight"] * kinetic).sum()) < 1e-3 * (t["weight"] * kinetic.abs()).sum()


def test_an_envelope_the_power_model_states_and_the_system_does_not_is_said():
    """A power model whose campaign's drive.toml stated an envelope, flown with a system
    file that states none: drive_in_force says it is not flown; with the system's own
    envelope nothing is said."""
    from optimize.system.drive_in_force import drive_in_force

    model = dataclasses.replace(paper_model(), drive={
        "nominal_power_w": 8200.0, "max_speed_rpm": 1500.0, "max_torque_nm": 78.0,
        "base_speed_rpm": 1000.0, "source": "test drive.toml"})
    plain = system_from_dict(_system(), "plain.toml")
    drive, how = drive_in_force(plain, drive_model=model)
    lines = how.lines(drive)
    assert any("states a torque-speed envelope (base_speed_rpm)" in line and "not flown" in line
               for line in lines), lines
    own = system_from_dict(_system(drive__base_speed_rpm=1200.0), "own.toml")
    assert drive_in_force(own, drive_model=model)[1].envelope_note == ""


def test_a_reel_jerk_limit_holds_and_is_reported_in_every_kind():
    """[winch] max_reel_jerk_m_s3 = 50 on the paper's kite, elec-lim at 7 m/s from the
    stored guess (whose jerk reaches 90 m/s^3): the optimum's |l'''| (the control, one
    value per interval) stays within 50 m/s^3 at every point, sits on it, and the bound
    is reported; the header line states it."""
    system = system_from_dict(_system(winch__max_reel_jerk_m_s3=50.0), "jerk.toml")
    assert "reel jerk <= 50 m/s^3 (all kinds)" in system.drivetrain_line()
    model = paper_model()
    flown = system.in_force(drive_in_force(system, drive_model=model)[0])
    assert flown.winch.max_reel_jerk_m_s3 == 50.0
    res = start(build_ocp(kite_dae(*system.model_params()), model, OcpOptions(), system=flown),
                Scenario.of_kind("elec-lim", 7.0))
    assert res.success, res.status
    jerk = res.trajectory["dddl_m_s3"].abs()
    assert jerk.max() <= 50.0 + 1e-6 and jerk.max() > 49.9
    assert "reel_jerk_limit" in res.active_bounds


@pytest.mark.parametrize("value", [0.0, -10.0])
def test_a_non_positive_jerk_limit_names_the_key(value):
    with pytest.raises(InputError, match="max_reel_jerk_m_s3"):
        system_from_dict(_system(winch__max_reel_jerk_m_s3=value), "bad.toml")


def test_the_drive_model_protocol_says_everything_optimize_uses():
    """Every attribute optimize reads of a ``drive_model`` (a name or an attribute of that
    name) is declared by :class:`kernel.drive.DriveModel`, and the power
    model has each."""
    import ast
    from pathlib import Path

    from kernel.drive import DriveModel

    declared = {n for n in vars(DriveModel) if not n.startswith("_")}
    declared |= set(DriveModel.__annotations__)
    used = set()
    for path in (Path(__file__).resolve().parent.parent / "optimize").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and (
                    (isinstance(node.value, ast.Name) and node.value.id == "drive_model")
                    or (isinstance(node.value, ast.Attribute)
                        and node.value.attr == "drive_model")):
                used.add(node.attr)
    assert used and used <= declared, sorted(used - declared)
    assert all(hasattr(paper_model(), name) for name in declared)


def test_the_power_model_is_the_drive_model_optimize_reads():
    """Every attribute and method the DriveModel protocol declares is the power model's, and
    no module of optimize reads the polynomial's arrays or picks a term by its exponents
    (the copper term, the mechanical term: the loss model's own, fitting.power_model)."""
    import inspect
    import re
    from pathlib import Path

    from kernel.drive import DriveModel

    model = paper_model()
    declared = [*DriveModel.__annotations__,
                *(n for n, v in vars(DriveModel).items()
                  if inspect.isfunction(v) and not n.startswith("_"))]
    assert {"thermal", "copper_w_per_nm2", "carried", "to_dict", "sha256"} <= set(declared)
    assert [n for n in declared if not hasattr(model, n)] == []
    root = Path(__file__).resolve().parent.parent / "optimize"
    reach = re.compile(r"coefficients_rpm|covariance_rpm|\.terms\b|\(0, 2\)|\(1, 1\)")
    found = [f"{p.relative_to(root)}:{m.group()}" for p in sorted(root.rglob("*.py"))
             for m in reach.finditer(p.read_text(encoding="utf-8"))]
    assert found == []
    # the AEP's and the cycle verdict's bands are the loss model's own (basis, of_basis,
    # sigma_of_basis): neither picks the polynomial apart
    terms = re.compile(r"coefficients_rpm|\.terms\b")
    for place in ("energy", "cycle"):
        found = [f"{p.name}:{m.group()}" for p in sorted((root.parent / place).rglob("*.py"))
                 for m in terms.finditer(p.read_text(encoding="utf-8"))]
        assert found == [], place
