"""The drive rating: drive.toml and session.toml keys, their lookup, and what a fit uses."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from fitting.rating import resolve_drive
from kernel.drive import Drive
from kernel.drive_file import (
    drive_toml,
    find_drive_file,
    load_drive_file,
    session_drive,
)
from kernel.errors import InputError


def test_drive_toml_round_trip_and_bad_values(tmp_path):
    rating = Drive.rating(150_000.0, 12_000.0, 358.1, source='EV "class" datasheet')
    path = tmp_path / "drive.toml"
    path.write_text(drive_toml(rating))
    assert load_drive_file(path) == rating.to_dict()
    path.write_text("nominal_power_w = -5.0\n")
    with pytest.raises(InputError) as err:
        load_drive_file(path)
    assert "nominal_power_w" in err.value.describe() and str(path) in err.value.describe()
    path.write_text("nominal_power_kw = 150\n")
    with pytest.raises(InputError, match="unknown key 'nominal_power_kw'"):
        load_drive_file(path)


def test_lookup_stops_at_the_campaign_root_and_session_keys_win(tmp_path):
    campaign = tmp_path / "lab" / "campaign"
    session = campaign / "run_01"
    session.mkdir(parents=True)
    (tmp_path / "lab" / "drive.toml").write_text("max_speed_rpm = 1.0\n")  # above the root
    assert find_drive_file(session, [campaign]) is None
    paper = Drive.rating(8200.0, 1500.0, 78.0, source="paper")
    (campaign / "drive.toml").write_text(drive_toml(paper))
    found = find_drive_file(session, [campaign])
    assert found == (campaign / "drive.toml").resolve()
    drive = session_drive({"max_torque_nm": 90.0}, session / "session.toml", found, "drive.toml")
    assert drive["max_torque_nm"] == 90.0 and drive["nominal_power_w"] == 8200.0
    assert drive["sources"]["max_torque_nm"] == "run_01/session.toml"
    assert drive["sources"]["max_speed_rpm"] == "drive.toml"
    assert session_drive({}, session / "session.toml", None, "") is None


def _store(tmp_path, drives: dict) -> tuple:
    store = tmp_path / "store"
    store.mkdir(parents=True)
    manifest = {"schema": "drivebench.store", "schema_version": 1,
                "sessions": {sid: {"drive": d} for sid, d in drives.items()}}
    (store / "manifest.json").write_text(json.dumps(manifest))
    frame = pd.DataFrame({"session_id": list(drives), "speed_rpm": [1000.0, -2000.0],
                          "torque_nm": [50.0, 40.0], "p_mech_w": [5236.0, -8378.0]})
    return store, frame


def test_fit_takes_the_manifest_rating_or_says_it_stands_in(tmp_path):
    d = {"nominal_power_w": 8200.0, "max_speed_rpm": 1500.0, "sources": {}, "source": "x"}
    store, frame = _store(tmp_path, {"a": d, "b": d})
    rating, notes = resolve_drive(store, frame)
    assert (rating.nominal_power_w, rating.max_speed_rpm) == (8200.0, 1500.0)
    # no torque limit stated anywhere: the measured maximum (50 N m) stands in, said so
    assert rating.max_torque_nm == 50.0 and len(notes) == 1 and "max_torque_nm" in notes[0]
    rating, _ = resolve_drive(store, frame, {"max_torque_nm": 78.0})
    assert rating.max_torque_nm == 78.0 and "command line" in rating.source
    other = {**d, "max_speed_rpm": 3000.0}
    store2, frame2 = _store(tmp_path / "x", {"a": d, "b": other})
    with pytest.raises(InputError, match="disagree on the drive rating max_speed_rpm"):
        resolve_drive(store2, frame2)


def test_sensor_ranges_not_stated_come_from_the_drive_rating_or_stop(tmp_path):
    from dataclasses import replace

    from bench.ingest.session import RANGE_OVER_RATING, Session, complete_ranges

    stated = {"speed": 3000.0, "torque": None, "power": None}
    s = Session(folder=tmp_path / "run_01", session_id="run_01", kind="timeseries",
                mode="motor", gear_ratio=3.0, measured_side="motor", speed_sign=1, torque_sign=1,
                ranges=stated, raw={})
    rating = {"nominal_power_w": 8200.0, "max_speed_rpm": 1500.0, "max_torque_nm": 78.0}
    done, note = complete_ranges(s, rating)
    # a stated range is kept; the others are the rating's, carried to the motor shaft (1:3)
    assert done.ranges["speed"] == 3000.0
    assert done.ranges["torque"] == pytest.approx(RANGE_OVER_RATING * 78.0 / 3.0)
    assert done.ranges["power"] == pytest.approx(RANGE_OVER_RATING * 8200.0)
    assert "torque_range_nm" in note and "power_range_w" in note and "speed" not in note
    # every range stated: nothing to say
    full = replace(s, ranges={"speed": 1.0, "torque": 2.0, "power": 3.0})
    assert complete_ranges(full, None) == (full, None)
    # neither stated nor in a drive rating: said, with the keys to write
    _, note = complete_ranges(s, None)
    assert "no sensor range and no drive rating given for torque_range_nm, power_range_w" \
        in note and "drive.toml" in note
