"""System files (issue 11 §2): the shipped ones load, and every kind of bad input is an
InputError naming the file and the key."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from kernel.errors import InputError
from optimize.model.params import AeroCoefficients, KiteParams, WindModel
from optimize.paper_model import paper_model
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system, system_from_dict

SHIPPED = ("highwind", "highwind_drivetrain", "ap2", "megawes")


def _data(name: str = "highwind") -> dict:
    return tomllib.loads(shipped_system_path(name).read_text())


def _error(data: dict) -> str:
    with pytest.raises(InputError) as info:
        system_from_dict(data, "my_kite.toml")
    text = str(info.value)
    assert "my_kite.toml" in text  # every error names the file
    return text


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_systems_load_with_a_positive_definite_inertia(name):
    system = load_system(shipped_system_path(name))
    assert system.name == name and len(system.sha256) == 64
    assert system.text == shipped_system_path(name).read_text()
    assert system.ground_clearance_m() >= 0.5 * system.kite.span_m


def test_highwind_file_is_the_package_defaults():
    # the paper's values (docs/paper_figures.md §2), written once as dataclass defaults and
    # once in the file
    system = load_system()
    assert system.kite_params() == KiteParams()
    assert system.aero_coefficients() == AeroCoefficients()
    assert system.wind_model() == WindModel()
    rating = drive_in_force(system, drive_model=paper_model())[0]
    # the file's drive is the paper model's rating
    flown = system.in_force(rating).drive
    assert {k: getattr(flown, k) for k in ("max_speed_rpm", "max_torque_nm",
                                           "nominal_power_w")} == {
        k: getattr(paper_model().drive, k) for k in ("max_speed_rpm", "max_torque_nm",
                                                     "nominal_power_w")}


def test_only_the_paper_system_says_it_is_the_papers():
    """highwind and highwind_drivetrain (the paper's wing and drive, with its estimated
    inertia: the comparison shows what the inertia moves) are the paper's; no other."""
    for name in SHIPPED:
        assert load_system(shipped_system_path(name)).paper_system is name.startswith(
            "highwind")
    data = _data()
    del data["system"]["paper_system"]  # optional: a system is not the paper's by default
    assert system_from_dict(data, "x.toml").paper_system is False


def test_hash_ignores_comments_and_key_order():
    text = shipped_system_path().read_text()
    data = tomllib.loads(text)
    again = system_from_dict(dict(reversed(list(data.items()))), "x.toml", "# other comments")
    assert again.sha256 == load_system().sha256
    changed = _data()
    changed["kite"]["mass_kg"] = 8.0
    assert system_from_dict(changed, "x.toml").sha256 != load_system().sha256


@pytest.mark.parametrize(("section", "key", "value", "words"), [
    ("kite", "mass_kg", -7.5, "[kite] mass_kg"),
    ("kite", "mass_kg", "heavy", "[kite] mass_kg"),
    ("kite", "mass_kg", True, "[kite] mass_kg"),
    ("kite", "span_m", 0.0, "[kite] span_m"),
    ("kite", "inertia_xz_kg_m2", 0.7, "not positive definite"),
    ("kite", "inertia_yy_kg_m2", -0.1, "[kite] inertia_yy_kg_m2"),
    ("winch", "drum_radius_m", 0.0, "[winch] drum_radius_m"),
    ("tether", "diameter_m", -0.001, "[tether] diameter_m"),
    ("aero", "alpha_max_deg", -10.0, "[aero] alpha_max_deg"),
    ("aero", "cl_alpha", -1.0, "[aero] cl_alpha"),
    ("wind", "profile", "linear", "[wind] profile"),
    ("bounds", "period_max_s", 0.5, "[bounds] period_max_s"),
    ("bounds", "tether_length_max_m", 0.5, "[bounds] tether_length_max_m"),
    ("bounds", "max_line_angle_deg", 95.0, "[bounds] max_line_angle_deg"),
    ("system", "paper_system", "yes", "[system] paper_system"),
])
def test_wrong_types_and_non_physical_values_name_the_key(section, key, value, words):
    data = _data()
    data[section][key] = value
    assert words in _error(data)


def test_unknown_and_missing_keys_and_sections_are_errors():
    data = _data()
    data["kite"]["mass_lb"] = 16.5
    assert "[kite] mass_lb: unknown key" in _error(data)
    data = _data()
    del data["aero"]["cm_q"]
    assert "[aero] cm_q: missing" in _error(data)
    data = _data()
    data["winch2"] = {}
    assert "[winch2]: unknown section" in _error(data)
    data = _data()
    del data["bounds"]
    assert "[bounds]: missing section" in _error(data)
    data = _data()
    data["wind"]["exponent"] = 0.14  # a power-law key with the log law
    assert "[wind] exponent" in _error(data)


def test_power_law_profile_and_optional_drive_keys():
    data = _data()
    del data["wind"]["roughness_length_m"]
    data["wind"].update(profile="power", exponent=0.14)
    wind = system_from_dict(data, "x.toml").wind_model()
    assert wind.power_law_exponent == 0.14 and wind.roughness_length_m == 0.0
    # a drive limit missing from the file and from the power model is an error naming it
    data = _data()
    del data["drive"]["max_torque_nm"]
    system = system_from_dict(data, "x.toml")

    class NoRating:  # a version-1 power model file: no drive rating
        drive = None
        nominal_power_w = 20e3

    with pytest.raises(InputError, match=r"\[drive\] max_torque_nm"):
        drive_in_force(system, drive_model=NoRating())
    # a key the file leaves out comes from the power model's rating, and the source says so
    model = paper_model()
    rating = drive_in_force(system, Path("paper.json"), drive_model=model)[0]
    assert rating.max_torque_nm == model.drive.max_torque_nm
    assert "max_torque_nm from paper.json" in rating.source
    # the file's own keys are in force, not the power model's
    data = _data()
    data["drive"].update(max_speed_rpm=1200.0, max_torque_nm=70.0)
    rating = drive_in_force(system_from_dict(data, "x.toml"), drive_model=model)[0]
    assert (rating.max_speed_rpm, rating.max_torque_nm) == (1200.0, 70.0)


def test_unreadable_and_non_toml_files(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        load_system(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[kite\nmass_kg = 1\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_system(bad)


def test_cli_exit_code_2_on_a_bad_system_file(tmp_path):
    from drivebench.cli import main

    data = shipped_system_path().read_text().replace("mass_kg = 7.5", "mass_kg = -7.5")
    path = tmp_path / "neg.toml"
    path.write_text(data)
    assert main(["optimize", "--system", str(path), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


def test_highwind_drivetrain_is_highwind_with_its_estimated_inertia():
    """highwind_drivetrain.toml is highwind.toml with the drum and rotor inertia its
    comments estimate (0.04 and 0.057 kg m^2): every other key is the same."""
    base, heavy = _data("highwind"), _data("highwind_drivetrain")
    assert heavy["winch"].pop("drum_inertia_kg_m2") == 0.04
    assert heavy["drive"].pop("rotor_inertia_kg_m2") == 0.057
    for key in ("name", "description"):
        base["system"].pop(key), heavy["system"].pop(key)
    assert heavy == base
