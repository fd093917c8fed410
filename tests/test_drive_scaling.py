"""The similarity law that carries a drive's losses to another rating, and the drive in force.

Truths: the base model evaluated at the corresponding operating point (the law's
definition, evaluated through the base model, not through the carried
coefficients), the closed form P_mech = omega T, and the sign convention (a real
drive draws more than it delivers when motoring, returns less than it receives
when generating).
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

from drivebench.cli import main
from kernel.drive import DRIVE_KEYS, OPTIONAL_DRIVE_KEYS
from kernel.errors import InputError
from optimize.model.drivetrain import RPM_PER_RAD_S, carry_power_model
from optimize.paper_model import paper_model
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system, system_from_dict

RATIOS = [(1.0, 1.0), (0.6366, 3.831), (0.3979, 919.5), (2.0, 0.5)]


def _p_mech_w(speed_rpm, torque_nm):
    return speed_rpm / RPM_PER_RAD_S * torque_nm


def _box(speed_rpm: float, torque_nm: float):
    """A grid over both quadrants of a rated box, away from the axes."""
    n = np.concatenate([np.linspace(-speed_rpm, -0.1 * speed_rpm, 7),
                        np.linspace(0.1 * speed_rpm, speed_rpm, 7)])
    t = np.linspace(0.1 * torque_nm, torque_nm, 6)
    return np.meshgrid(n, t)


@pytest.mark.parametrize(("k_n", "k_t"), RATIOS)
def test_carried_efficiency_at_corresponding_points_is_the_base_machines(k_n, k_t):
    base = paper_model()
    carried = carry_power_model(base, k_n, k_t)
    n, t = _box(1500.0, 78.0)
    eta_base = _p_mech_w(n, t) / base.p_elec_w(n, t)
    eta_carried = _p_mech_w(k_n * n, k_t * t) / carried.p_elec_w(k_n * n, k_t * t)
    np.testing.assert_allclose(eta_carried, eta_base, rtol=1e-12)
    # losses scale with the machine: k_n k_T times the base loss at the corresponding point
    loss_base = base.p_elec_w(n, t) - _p_mech_w(n, t)
    loss = carried.p_elec_w(k_n * n, k_t * t) - _p_mech_w(k_n * n, k_t * t)
    np.testing.assert_allclose(loss, k_n * k_t * loss_base, rtol=1e-9)
    assert carried.nominal_power_w == pytest.approx(k_n * k_t * base.nominal_power_w)
    assert carried.drive.max_speed_rpm == pytest.approx(k_n * 1500.0)
    assert carried.drive.max_torque_nm == pytest.approx(k_t * 78.0)


def test_carried_model_keeps_the_sign_convention_and_scales_domain_and_covariance():
    base = paper_model()
    cov = np.diag([1.0, 2e-8, 1e-4, 1e-6])
    from dataclasses import replace

    base = replace(base, covariance_rpm=tuple(map(tuple, cov)))
    k_n, k_t = 0.6366, 3.831
    carried = carry_power_model(base, k_n, k_t)
    n, t = _box(k_n * 1500.0, k_t * 78.0)
    p_mech, p_elec = _p_mech_w(n, t), carried.p_elec_w(n, t)
    # losses > 0: generating returns less than the shaft gives (where it returns anything;
    # at low torque and high speed the losses exceed the shaft power), motoring draws more
    assert np.all(p_elec > p_mech)
    gen, mot = (n < 0) & (p_elec < 0), n > 0
    assert gen.sum() > 0.5 * (n < 0).sum()
    assert np.all(np.abs(p_elec[gen]) < np.abs(p_mech[gen]))
    assert np.all(np.abs(p_elec[mot]) > np.abs(p_mech[mot]))
    # the rating's corner: more drawn than delivered when motoring (the old law drew less)
    corner = carried.p_elec_w(k_n * 1500.0, k_t * 78.0)
    assert corner > _p_mech_w(k_n * 1500.0, k_t * 78.0)
    # the validity domain's corners move with the ratios
    assert [k_n * 1500.0, k_t * 78.0] in [[pytest.approx(a), pytest.approx(b)]
                                          for a, b in carried.domain["motor"]]
    # covariance: the same factors k_n^(1-i) k_T^(1-j) on both sides
    f = np.array([k_n ** (1 - i) * k_t ** (1 - j) for i, j in base.terms])
    np.testing.assert_allclose(np.array(carried.covariance_rpm), cov * np.outer(f, f))


def test_carried_shipped_drives_generate_less_than_the_shaft_and_motor_more():
    for name in ("ap2", "megawes"):
        r, drive = drive_in_force(load_system(shipped_system_path(name)))
        assert drive.carried
        n, t = _box(r.max_speed_rpm, r.max_torque_nm)
        p_mech, p_elec = _p_mech_w(n, t), r.power_model.p_elec_w(n, t)
        assert np.all(p_elec - p_mech > 0), name  # losses > 0 over the rated box
        # losses at corresponding points: the paper drive's, times k_n k_T and the loss
        # ratio of the file's law (AP2 "similarity": 1, its efficiency kept; MegAWES
        # "similarity-ie3": the IE3 class's, below 1)
        base = paper_model()
        k_n, k_t = drive.speed_ratio, drive.torque_ratio
        base_loss = base.p_elec_w(n / k_n, t / k_t) - _p_mech_w(n / k_n, t / k_t)
        np.testing.assert_allclose(p_elec - p_mech, drive.loss_ratio * k_n * k_t * base_loss,
                                   rtol=1e-9)
        assert (drive.loss_ratio == 1.0) == (name == "ap2")
        assert k_n * k_t * base.nominal_power_w == pytest.approx(r.nominal_power_w)


@pytest.mark.parametrize("lam", [0.429, 1.0, 1.7])
def test_a_loss_ratio_scales_the_losses_and_keeps_the_shaft_power(lam):
    from dataclasses import replace

    cov = np.diag([1.0, 2e-8, 1e-4, 1e-6])
    base = replace(paper_model(), covariance_rpm=tuple(map(tuple, cov)))
    k_n, k_t = 0.0859, 4260.0
    plain = carry_power_model(base, k_n, k_t)
    carried = carry_power_model(base, k_n, k_t, loss_ratio=lam)
    n, t = _box(k_n * 1500.0, k_t * 78.0)
    p_mech = _p_mech_w(n, t)
    # P_elec = P_mech + lam (the law's loss), the law's loss through the base model
    law_loss = k_n * k_t * (base.p_elec_w(n / k_n, t / k_t) - _p_mech_w(n / k_n, t / k_t))
    np.testing.assert_allclose(carried.p_elec_w(n, t) - p_mech, lam * law_loss, rtol=1e-9)
    np.testing.assert_allclose(np.array(carried.covariance_rpm),
                               lam**2 * np.array(plain.covariance_rpm), rtol=1e-12)
    assert carried.provenance["loss_ratio"] == lam


@pytest.mark.parametrize("name", ["highwind", "highwind_drivetrain", "ap2", "megawes"])
def test_the_drive_in_force_is_the_systems_drive_with_its_rating(name):
    """One drive in force: the system's [drive] every key kept (envelope, inertia, losses,
    scaling), the rating keys stated, what the OCP flies but for the source, which says
    where each came from, and its losses; a carried model records its rating part alone
    (the rating keys and that source: the model's file and hash as before)."""
    system = load_system(shipped_system_path(name))
    d, how = drive_in_force(system)
    own = system.drive
    for key in ("base_speed_rpm", "rotor_inertia_kg_m2", "losses", "scaling",
                "continuous_torque_nm", "overload"):
        assert getattr(d, key) == getattr(own, key), key
    assert d.source.startswith(f"{name}.toml [drive]: {own.source}")
    flown = system.in_force(d).drive
    assert dataclasses.replace(flown, source=None) == dataclasses.replace(d, source=None)
    assert flown.source == own.source
    part = d.rating_part()
    stated = {f.name for f in dataclasses.fields(part) if getattr(part, f.name) is not None}
    assert stated <= {*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS, "source"} and part.source == d.source
    assert d.power_model is not None and part.power_model is None
    assert d.thermal_model is d.power_model.thermal and d.keys() == {
        f.name: getattr(d, f.name) for f in dataclasses.fields(d) if f.name != "power_model"}
    if how.carried:
        assert d.power_model.drive == part
    else:
        assert d.power_model.sha256 == paper_model().sha256


def test_a_carried_model_is_the_same_wherever_its_system_file_lies(tmp_path):
    """The carried model's SHA-256 (in every stored solve's key) does not hold where the
    checkout lies: AP2's file (the shipped paper losses) and one whose losses and nominal
    power come from a power model beside it, each copied to two folders."""
    from fitting.model_file import save_power_model

    text = shipped_system_path("ap2").read_text()
    own = text.replace('losses = "paper"', 'losses = "losses/base.json"').replace(
        "nominal_power_w = 20000.0", "")
    assert own != text and "nominal_power_w" not in tomllib.loads(own)["drive"]
    for i, body in enumerate((text, own)):
        forces = []
        for where in ("a", "deep/er/b"):
            folder = tmp_path / str(i) / where
            save_power_model(paper_model(), folder / "losses" / "base.json")
            (folder / "kite.toml").write_text(body)
            forces.append(drive_in_force(load_system(folder / "kite.toml")))
        (first, how), (second, _) = forces
        assert how.carried and first.power_model.sha256 == second.power_model.sha256
        assert first.source == second.source
        assert str(tmp_path) not in first.source
    assert first.source.startswith("kite.toml [drive]: ")
    assert first.source.endswith("; nominal_power_w from losses/base.json")


def test_a_loss_ratio_needs_the_shaft_power_term():
    from dataclasses import replace

    base = paper_model()
    keep = [i for i, term in enumerate(base.terms) if tuple(term) != (1, 1)]
    no_nt = replace(base, terms=tuple(base.terms[i] for i in keep),
                    coefficients_rpm=tuple(base.coefficients_rpm[i] for i in keep))
    with pytest.raises(ValueError, match="speed x torque term"):
        carry_power_model(no_nt, 1.0, 2.0, loss_ratio=0.5)


def _ap2_data() -> dict:
    return tomllib.loads(shipped_system_path("ap2").read_text())


def test_a_drive_far_from_its_power_model_needs_a_scaling_key():
    data = _ap2_data()
    del data["drive"]["scaling"]
    system = system_from_dict(data, "my_kite.toml")
    with pytest.raises(InputError, match=r'scaling = "similarity"') as err:
        drive_in_force(system)
    assert "my_kite.toml" in str(err.value)
    # "none": the losses as they are, the rating the system's
    data["drive"]["scaling"] = "none"
    drive, how = drive_in_force(system_from_dict(data, "my_kite.toml"))
    assert not how.carried and drive.power_model.sha256 == paper_model().sha256
    assert drive.max_torque_nm == 360.0
    # within x1.5 of the model's rating: used as it is, no key needed
    data = _ap2_data()
    del data["drive"]["scaling"]
    data["drive"].update(max_speed_rpm=1400.0, max_torque_nm=100.0, nominal_power_w=9000.0)
    assert not drive_in_force(system_from_dict(data, "my_kite.toml"))[1].carried


def test_bench_optimize_stops_with_exit_2_naming_the_key(tmp_path, capsys):
    data = _ap2_data()
    text = shipped_system_path("ap2").read_text().replace('scaling = "similarity"\n', "")
    assert "scaling" not in tomllib.loads(text)["drive"] and data["drive"]["scaling"]
    path = tmp_path / "my_kite.toml"
    path.write_text(text)
    code = main(["optimize", "--system", str(path), "--wind-grid", "7",
                 "--out", str(tmp_path / "o")])
    assert code == 2
    err = capsys.readouterr().err
    assert "scaling" in err and str(path) in err
    assert not (tmp_path / "o").exists()


def test_losses_path_is_relative_to_the_system_file(tmp_path):
    from fitting.model_file import save_power_model

    folder = tmp_path / "kite"
    folder.mkdir()
    save_power_model(paper_model(), folder / "my_drive.json")
    data = _ap2_data()
    data["drive"]["losses"] = "my_drive.json"
    system = system_from_dict(data, str(folder / "kite.toml"))
    _, drive = drive_in_force(system)
    assert drive.model_path == Path(folder / "my_drive.json") and drive.carried
    # --drive-model overrides the file's losses
    _, other = drive_in_force(system, Path(folder / "my_drive.json"))
    assert other.losses_note == "--drive-model"
