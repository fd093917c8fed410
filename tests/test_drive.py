"""The one drive type (kernel.drive.Drive): its dict form's reader and writer, its checks,
and the figures derived from it, against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kernel.drive import Drive, dict_problem
from kernel.errors import InputError
from optimize.system.sections import SECTIONS


def test_the_system_file_section_is_the_drive_type():
    assert SECTIONS["drive"] is Drive


def test_the_dict_form_round_trips_and_leaves_out_what_is_not_stated():
    drive = Drive.rating(8200.0, 1500.0, 78.0, source="paper", continuous_torque_nm=40.0,
                         envelope_speed_rpm=[0, 1000, 1500], envelope_torque_nm=[78, 78, 52])
    data = drive.to_dict()
    assert list(data) == ["nominal_power_w", "max_speed_rpm", "max_torque_nm",
                          "continuous_torque_nm", "envelope_speed_rpm", "envelope_torque_nm",
                          "source"]
    assert data["envelope_speed_rpm"] == [0.0, 1000.0, 1500.0]
    back = Drive.from_dict(data, rating=True)
    assert back == drive and back.envelope_torque_nm == (78.0, 78.0, 52.0)


def test_the_reader_names_the_file_and_the_key(tmp_path):
    path = tmp_path / "power_model.json"
    with pytest.raises(InputError) as err:
        Drive.from_dict({"nominal_power_w": 1.0, "max_speed_rpm": 1.0, "max_torque_nm": -2.0},
                        path, rating=True)
    assert str(path) in err.value.describe() and "drive.max_torque_nm" in err.value.describe()
    with pytest.raises(InputError, match="unknown key 'max_torque_kgm'"):
        Drive.from_dict({"max_torque_kgm": 1.0}, path)
    with pytest.raises(InputError, match="drive.losses"):
        Drive.from_dict({"losses": 3}, path)
    # a manifest's section (every key, None where not stated) reads as it is
    section = Drive(max_torque_nm=78.0, losses="paper").keys()
    assert Drive.from_dict(section) == Drive(max_torque_nm=78.0, losses="paper")
    assert dict_problem({"nominal_power_w": 1.0, "max_speed_rpm": 2.0}) is not None
    assert dict_problem({"losses": "paper"}) is not None  # not a rating key


def test_a_rating_is_checked_when_made():
    with pytest.raises(ValueError, match="overload"):
        Drive.rating(1.0, 1.0, 1.0, overload=0.5)
    with pytest.raises(ValueError, match="base_speed_rpm"):
        Drive.rating(1.0, 1.0, 1.0, base_speed_rpm=10.0, envelope_speed_rpm=(0.0, 1.0),
                     envelope_torque_nm=(1.0, 1.0))
    assert isinstance(Drive.rating(8200, 1500, 78).max_torque_nm, float)


def test_derived_figures_against_hand_values():
    base = Drive.rating(8200.0, 1500.0, 78.0, base_speed_rpm=1000.0)
    # 78 N m up to 1000 rpm, 78 x 1000 / |n| above, either sign
    assert base.largest_torque_nm([-1500.0, 500.0, 1250.0]) == pytest.approx([52.0, 78.0, 62.4])
    assert base.constant_power_w() == pytest.approx(78.0 * 1000.0 * math.pi / 30.0)
    assert base.constant_power_w(600.0) == pytest.approx(78.0 * 600.0 * math.pi / 30.0)
    assert base.peak_power_w() == pytest.approx(78.0 * 1000.0 * math.pi / 30.0)
    assert base.corner_rpm() == 1000.0
    table = Drive.rating(8200.0, 1500.0, 70.0, envelope_speed_rpm=(0.0, 1000.0, 1500.0),
                         envelope_torque_nm=(78.0, 78.0, 40.0))
    # the table capped by the torque limit; 59 N m halfway down its last segment
    assert table.largest_torque_nm([0.0, 1250.0, 3000.0]) == pytest.approx([70.0, 59.0, 40.0])
    # T n at the table's points and the speed limit: 70 x 1000 rpm is the largest
    assert table.peak_power_w() == pytest.approx(70.0 * 1000.0 * math.pi / 30.0)
    plain = Drive.rating(8200.0, 1500.0, 78.0, continuous_torque_nm=40.0)
    assert np.all(plain.largest_torque_nm(np.linspace(-2000, 2000, 5)) == 78.0)
    assert plain.rms_torque_limit_nm == 40.0 and plain.corner_rpm() == 1500.0
    assert not plain.has_envelope() and base.has_envelope() and table.has_envelope()
    assert Drive.rating(1.0, 1.0, 1.0, continuous_torque_nm=2.0).rms_torque_limit_nm is None
