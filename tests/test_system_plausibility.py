"""Plausibility of system files: what cannot fly stops with exit 2 before any solve,
naming the file and the key; every real kite from 7.5 kg to 6.9 t passes."""

from __future__ import annotations

import copy
import math
import time
import tomllib

import pytest

from kernel.drive import Drive
from kernel.errors import InputError
from optimize.system.plausibility import check_drive_holds_kite
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system, system_from_dict

SHIPPED = ("highwind", "highwind_drivetrain", "ap2", "megawes")


def _data(name: str = "highwind") -> dict:
    return copy.deepcopy(tomllib.loads(shipped_system_path(name).read_text()))


def _refused(data: dict) -> str:
    with pytest.raises(InputError) as info:
        system_from_dict(data, "my_kite.toml")
    assert "my_kite.toml" in str(info.value)
    return str(info.value)


def glider() -> dict:
    """A 30 kg, 12 m^2 rigid glider kite (aspect ratio 12), inertias of a uniform wing."""
    data = _data("ap2")
    span, area, mass = 12.0, 12.0, 30.0
    data["kite"].update(mass_kg=mass, reference_area_m2=area, span_m=span, chord_m=area / span,
                        inertia_xx_kg_m2=mass * span**2 / 12, inertia_yy_kg_m2=mass * 0.3,
                        inertia_zz_kg_m2=mass * span**2 / 12 + mass * 0.3,
                        inertia_xz_kg_m2=0.0)
    data["tether"].update(diameter_m=0.004, max_force_n=4000.0)
    return data


def soft_kite() -> dict:
    """A leading-edge-inflatable soft kite: 25 m^2, 8.5 m span, 11 kg (aspect ratio 2.9)."""
    data = glider()
    span, area, mass = 8.5, 25.0, 11.0
    data["kite"].update(mass_kg=mass, reference_area_m2=area, span_m=span, chord_m=area / span,
                        inertia_xx_kg_m2=mass * span**2 / 12, inertia_yy_kg_m2=mass * 1.0,
                        inertia_zz_kg_m2=mass * span**2 / 12 + mass * 1.0)
    data["aero"].update(cd0=0.08, cd_alpha2=0.5)  # a soft wing's polar: L/D about 5
    return data


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_kite_from_7_5_kg_to_6_9_t_is_plausible(name):
    system = load_system(shipped_system_path(name))
    assert 7.5 <= system.kite.mass_kg <= 6900
    check_drive_holds_kite(system, system.drive, "system file")


@pytest.mark.parametrize("make", [glider, soft_kite])
def test_other_real_kites_are_plausible(make):
    system_from_dict(make(), "kite.toml")


def test_shipped_limits_are_the_published_ones():
    # awebox ampyx_ap2_settings.py: tether force [50, 1800] N, airspeed [10, 32] m/s
    ap2 = load_system(shipped_system_path("ap2")).kite_limits()
    assert (ap2.max_tether_force_n, ap2.min_airspeed_m_s, ap2.max_airspeed_m_s) == (1800, 10, 32)
    # MegAWES: 3.6 GPa Dyneema, safety factor 1.5 on the 27.19 mm line: 1.39e6 N
    mega = load_system(shipped_system_path("megawes")).kite_limits()
    assert mega.max_tether_force_n == pytest.approx(3.6e9 * math.pi * 0.02719**2 / 4 / 1.5)
    assert mega.max_tether_force_n == pytest.approx(1.39e6, rel=3e-3)
    assert mega.max_airspeed_m_s == 120
    # the paper's kite has none (the paper's OCP has none): its optima stay the paper's
    hw = load_system().kite_limits()
    assert hw.max_tether_force_n is None and hw.max_airspeed_m_s is None


def test_tether_force_is_the_smaller_of_force_and_stress_limit():
    data = _data("megawes")
    data["tether"]["max_force_n"] = 1.0e6
    limits = system_from_dict(data, "x.toml").kite_limits()
    assert limits.max_tether_force_n == 1.0e6
    assert limits.sources["max_tether_force_n"] == "[tether] max_force_n"


def _drag_free(data: dict) -> None:
    for key in list(data["aero"]):
        if key.startswith("cd"):
            data["aero"][key] = 0.0


@pytest.mark.parametrize(("change", "key"), [
    (lambda d: d["aero"].update(cd0=-0.2), "[aero] cd0"),
    (_drag_free, "[aero] cd0"),
    (lambda d: d["aero"].update(cd0=1e-5, cd_alpha=0.0, cd_alpha2=0.0, cd_beta2=0.0),
     "[aero] cd0"),  # lift-to-drag beyond any wing
    (lambda d: d["aero"].update(cl0=-2.0), "[aero] cl0"),
    (lambda d: d["kite"].update(span_m=1e6), "[kite] span_m"),
    (lambda d: d["kite"].update(span_m=40.0), "[kite] span_m"),  # aspect ratio 2300
    (lambda d: d["kite"].update(mass_kg=1e6), "[kite] mass_kg"),
    (lambda d: d["kite"].update(mass_kg=2000.0), "[kite] mass_kg"),  # 2.9 t/m^2
    (lambda d: d["kite"].update(chord_m=5.0), "[kite] chord_m"),
    (lambda d: d["kite"].update(inertia_xx_kg_m2=5000.0), "[kite] inertia_xx_kg_m2"),
    (lambda d: d["kite"].update(inertia_zz_kg_m2=5.0), "[kite] inertia_zz_kg_m2"),
    (lambda d: d["bounds"].update(max_airspeed_m_s=12.0), "[bounds] max_airspeed_m_s"),
    (lambda d: d["tether"].update(max_force_n=50.0), "[tether] max_force_n"),
    (lambda d: d["tether"].update(tensile_strength_pa=3.6e9), "[tether] safety_factor"),
])
def test_what_cannot_fly_is_refused_naming_the_key(change, key):
    data = _data()
    change(data)
    assert key in _refused(data)


def test_megawes_at_1000_t_is_refused():
    data = _data("megawes")
    data["kite"]["mass_kg"] = 1.0e6
    assert "[kite] mass_kg" in _refused(data)


def test_a_drive_that_cannot_hold_the_weight_is_refused():
    system = load_system()  # 7.5 kg on a 0.1 m drum: 7.4 N m hold the weight
    check_drive_holds_kite(system, Drive(max_torque_nm=7.5), "system file")
    with pytest.raises(InputError, match=r"\[drive\] max_torque_nm: 7 N m"):
        check_drive_holds_kite(system, Drive(max_torque_nm=7.0), "system file")


def _value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return f'"{v}"' if isinstance(v, str) else repr(v)


def _toml(data: dict) -> str:
    """A system file's text (flat sections of numbers, strings and booleans)."""
    out = []
    for section, table in data.items():
        out.append(f"[{section}]")
        out += [f"{k} = {_value(v)}" for k, v in table.items()]
    return "\n".join(out) + "\n"


@pytest.mark.parametrize(("change", "key"), [
    (lambda d: d["aero"].update(cd0=-0.2), "[aero] cd0"),
    (_drag_free, "[aero] cd0"),
    (lambda d: d["kite"].update(span_m=1e6), "[kite] span_m"),
    (lambda d: d["kite"].update(mass_kg=1e6), "[kite] mass_kg"),
    # 100 kg on the paper's 0.1 m drum: its 78 N m hold 780 N, less than the weight
    (lambda d: d["kite"].update(mass_kg=100.0), "[drive] max_torque_nm"),
])
def test_bench_optimize_exits_2_before_any_solve(tmp_path, monkeypatch, capsys, change, key):
    import optimize.command
    from drivebench.cli import main

    def no_solve(*args, **kwargs):
        raise AssertionError("a solve started")

    monkeypatch.setattr(optimize.command, "run_sweep", no_solve)
    monkeypatch.chdir(tmp_path)  # no fit_out/ here: the paper's drive model
    data = _data()
    change(data)
    path = tmp_path / "bad_kite.toml"
    path.write_text(_toml(data))
    assert tomllib.loads(path.read_text()) == data
    t0 = time.perf_counter()
    code = main(["optimize", "--system", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(path) in err and key in err
    assert time.perf_counter() - t0 < 10  # seconds, not minutes of IPOPT
