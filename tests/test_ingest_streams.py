"""Loggers from 0.5 Hz to 10 kHz, single-stream logs, clock-time columns, signed torque.

Every session here is synthetic with a known truth (tests/ingest_fixtures.py,
tests/stream_fixtures.py); the tests match each recovered point to the hold it
lies in and compare its means with that hold's setpoint.
"""

from __future__ import annotations

from datetime import date, datetime

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest
from ingest_fixtures import make_timeseries_session, paper_p_elec, store_tree
from stream_fixtures import make_ev_export, make_german_logger

from bench.ingest import clock
from bench.ingest.daq_stream import open_daq_csv
from bench.ingest.pipeline import ingest
from bench.store.manifest import read_manifest
from bench.store.read import read_points
from drivebench.cli import main
from kernel.errors import InputError


def _match(points: pd.DataFrame, step_s, start_s: float = 0.0) -> np.ndarray:
    """Index of the hold each point's window lies in (window midpoint after the hold's step)."""
    mid = 0.5 * (points.t_start_s.to_numpy() + points.t_end_s.to_numpy()) - start_s
    return np.searchsorted(np.asarray(step_s), mid, side="right") - 1


@pytest.mark.parametrize("daq_hz, hold_s", [(1.0, 20.0), (5.0, 8.0)])
def test_low_rate_daq_recovers_every_plateau(tmp_path, daq_hz, hold_s):
    truth = make_timeseries_session(tmp_path / "c", daq_hz=daq_hz, hold_s=hold_s, markers=False)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = read_points(tmp_path / "store").sort_values("t_start_s")
    k = _match(pts, truth.step_times_s)
    # one point per setpoint, none straddling a step
    assert sorted(k.tolist()) == list(range(len(truth.setpoints)))
    s_true = np.array([truth.setpoints[i][0] for i in k])
    q_true = np.array([truth.setpoints[i][1] for i in k])
    n = pts.n_samples.to_numpy()
    # DAQ noise 1 rpm and 0.15 N m per sample: 5 standard errors of the window mean
    assert np.all(np.abs(pts.speed_rpm - s_true) < 5 * 1.0 / np.sqrt(n) + 0.05)
    assert np.all(np.abs(pts.torque_nm - q_true) < 5 * 0.15 / np.sqrt(n) + 0.02)
    # analyzer noise 3 W per record; 10 W also covers the 0.1 s record-interval mean
    assert np.all(np.abs(pts.p_elec_w - paper_p_elec(s_true, q_true)) < 10.0)


def test_10_khz_daq(tmp_path):
    truth = make_timeseries_session(tmp_path / "c", daq_hz=10_000.0, hold_s=5.0, markers=False)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = read_points(tmp_path / "store")
    k = _match(pts, truth.step_times_s)
    assert sorted(k.tolist()) == list(range(len(truth.setpoints)))
    entry = read_manifest(tmp_path / "store")["sessions"]["motor_01"]
    assert entry["timing"]["bin_s"] == pytest.approx(0.1)
    assert entry["timing"]["sample_interval_s"] == pytest.approx(1e-4)
    q_true = np.array([truth.setpoints[i][1] for i in k])
    assert np.all(np.abs(pts.torque_nm - q_true) < 0.02)  # 0.15 N m noise, ~10^4 samples


def test_zero_points_are_said_and_strict_fails(tmp_path, capsys):
    # holds of 1.5 s: no 2 s window anywhere
    make_timeseries_session(tmp_path / "c", hold_s=1.5, markers=False)
    store = tmp_path / "store"
    assert main(["ingest", str(tmp_path / "c"), "--store", str(store), "--no-progress"]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("NO POINTS"))
    assert "motor_01: 0 points:" in line
    before = store_tree(store)
    # --strict: exit 2, naming the session; the store unchanged
    assert main(["ingest", str(tmp_path / "c"), "--store", str(store), "--no-progress",
                 "--strict"]) == 2
    err = capsys.readouterr().err
    assert "motor_01" in err and "0 points" in err
    assert store_tree(store) == before


def test_ev_export_single_stream_signed_torque(tmp_path):
    truth = make_ev_export(tmp_path / "c")
    res = ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    entry = res.manifest["sessions"]["ev_01"]
    assert entry["clock_offset_s"] is None and "log" in entry["instruments"]
    pts = read_points(tmp_path / "store").sort_values("t_start_s")
    k = _match(pts, truth.step_s)
    assert sorted(k.tolist()) == list(range(truth.speed_rpm.size))
    # drum frame: torque >= 0 everywhere, generator points at negative speed
    assert (pts.torque_nm > 0).all()
    assert entry["points_per_quadrant"] == {
        "motor": int((truth.quadrant == "motor").sum()),
        "generator": int((truth.quadrant == "generator").sum())}
    assert (pts.quadrant.to_numpy() == truth.quadrant[k]).all()
    n = pts.n_samples.to_numpy()
    # noise per sample 3 rpm, 0.5 N m, 40 W: 5 standard errors, plus the settling tail: a
    # window may start while the speed is still within its steady tolerance (5 noise
    # sigmas, 15 rpm) of the level, up to 300 W of p_mech at 200 N m in the first samples,
    # some 30 W in the mean of ~50 (0.03 % of these 10-100 kW points)
    assert np.all(np.abs(pts.speed_rpm - truth.speed_rpm[k]) < 5 * 3.0 / np.sqrt(n) + 1.0)
    assert np.all(np.abs(pts.torque_nm - truth.torque_nm[k]) < 5 * 0.5 / np.sqrt(n) + 0.1)
    assert np.all(np.abs(pts.p_elec_w - truth.p_elec_w[k]) < 5 * 40.0 / np.sqrt(n) + 40.0)


def test_ev_export_without_signed_is_refused(tmp_path):
    make_ev_export(tmp_path / "c", signed=False)
    with pytest.raises(InputError) as exc:
        ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    msg = str(exc.value)
    assert "log.csv" in msg and "negative drum torque" in msg and "signed" in msg


def test_ev_export_with_a_wrong_p_mech_column_is_refused(tmp_path):
    make_ev_export(tmp_path / "c")
    m = tmp_path / "c" / "ev_01" / "mapping.toml"
    m.write_text(m.read_text().replace('"P_Mech [kW]"', '"Flux_3 [mWb]"'))
    with pytest.raises(InputError) as exc:
        ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    assert "Flux_3" in str(exc.value) and "p_mech" in str(exc.value)


def test_german_1hz_time_of_day_logger_with_gaps(tmp_path):
    start = datetime(2024, 3, 5, 23, 57, 30)
    truth = make_german_logger(tmp_path / "c", start=start)
    res = ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    entry = res.manifest["sessions"]["logger_de"]
    assert entry["start"] == start.isoformat()
    assert entry["timing"]["sample_interval_s"] == pytest.approx(1.0)
    assert entry["timing"]["n_gaps"] == 2
    pts = read_points(tmp_path / "store").sort_values("t_start_s")
    k = _match(pts, truth.step_s)
    expected = sorted(list(range(truth.speed_rpm.size)) + list(truth.split_holds))
    assert sorted(k.tolist()) == expected
    # the gaps: no window spans one (12 s inside hold 2; 25 s around the step into hold 6)
    mid2 = truth.step_s[2] + truth.hold_s / 2
    assert not ((pts.t_start_s < mid2 - 6) & (pts.t_end_s > mid2 + 6)).any()
    assert not ((pts.t_start_s < truth.step_s[6] - 10) & (pts.t_end_s > truth.step_s[6])).any()
    # through midnight: the time axis keeps increasing
    assert pts.t_end_s.max() > (datetime(2024, 3, 6) - start).total_seconds()
    q = entry["points_per_quadrant"]
    assert q == {"motor": int((truth.quadrant[k] == "motor").sum()),
                 "generator": int((truth.quadrant[k] == "generator").sum())} \
        and q == {"motor": 6, "generator": 3}
    n = pts.n_samples.to_numpy()
    # 1 Hz noise 1 rpm, 0.15 N m, 6 W: 5 standard errors of the window mean
    assert np.all(np.abs(pts.speed_rpm - truth.speed_rpm[k]) < 5 * 1.0 / np.sqrt(n) + 0.1)
    assert np.all(np.abs(pts.torque_nm - truth.torque_nm[k]) < 5 * 0.15 / np.sqrt(n) + 0.02)
    assert np.all(np.abs(pts.p_elec_w - truth.p_elec_w[k]) < 5 * 6.0 / np.sqrt(n) + 2.0)


def test_clock_parser_time_of_day_rolls_over_midnight():
    parse = clock.ClockParser(clock.TIME_OF_DAY, date(2024, 3, 5))
    a = parse(pa.array(["23:59:58,5", "23:59:59.5", None]))
    b = parse(pa.array(["00:00:00.5", "0:00:01"]))
    assert a[:2].tolist() == [0.0, 1.0] and np.isnan(a[2])
    assert b.tolist() == [2.0, 2.5]
    assert parse.start == datetime(2024, 3, 5, 23, 59, 58, 500000)


def test_clock_parser_iso_8601():
    parse = clock.ClockParser(clock.DATETIME)
    x = parse(pa.array(["2024-03-05T23:59:59.750", "2024-03-06 00:00:00.250"]))
    assert x.tolist() == [0.0, 0.5]
    zoned = clock.ClockParser(clock.DATETIME)
    y = zoned(pa.array(["2024-03-05T10:00:00+01:00", "2024-03-05T09:00:01Z"]))
    assert y.tolist() == [0.0, 1.0]


@pytest.mark.parametrize("header, cells, factor", [
    ("Time [us]", ["0", "250000", "500000"], 1e-6),
    ("Time [ms]", ["0", "250", "500"], 1e-3),
    ("Timestamp", ["2013-04-17T09:12:03.000", "2013-04-17T09:12:03.250",
                   "2013-04-17T09:12:03.500"], None),
    ("Uhrzeit", ["09:12:03", "09:12:03.25", "09:12:03.5"], None),
])
def test_time_column_formats(tmp_path, header, cells, factor):
    f = tmp_path / "daq.csv"
    f.write_text(f"{header},Speed [rpm],Torque [Nm]\n"
                 + "".join(f"{c},100,{k}\n" for k, c in enumerate(cells)))
    stream = open_daq_csv(f, day=date(2013, 4, 17))
    t = np.concatenate([c.values["time"] for c in stream.chunks()])
    assert t.tolist() == [0.0, 0.25, 0.5]
    if factor is None:
        assert stream.clock.start == datetime(2013, 4, 17, 9, 12, 3)


def test_bad_clock_cell_names_its_line(tmp_path):
    f = tmp_path / "daq.csv"
    rows = "".join(f"09:00:{s:02d},1,1\n" for s in range(10))
    f.write_text("Zeit,Speed [rpm],Torque [Nm]\n" + rows + "9h00,1,1\n")
    stream = open_daq_csv(f, day=date(2013, 4, 17))
    with pytest.raises(InputError) as exc:
        list(stream.chunks())
    assert exc.value.line == 12 and "9h00" in str(exc.value)


def _signed_table(root, torque_sign: str) -> tuple[np.ndarray, np.ndarray]:
    """A point table logged as speed > 0, torque < 0 in generator mode; drum-frame truth."""
    speed = np.array([500.0, 1000.0, -500.0, -1000.0])  # drum frame
    torque = np.array([20.0, 40.0, 30.0, 60.0])
    folder = root / "tab"
    folder.mkdir(parents=True)
    rows = ["Speed [rpm],Torque [Nm],P_el [W]"] + [
        f"{abs(s)},{q if s > 0 else -q},{paper_p_elec(s, q):.3f}"
        for s, q in zip(speed, torque, strict=True)]
    (folder / "points.csv").write_text("\n".join(rows) + "\n")
    (folder / "session.toml").write_text(f'''session_id = "tab"
kind = "operating_points"
mode = "motor"
gear_ratio = 1.0
measured_side = "drum"
speed_sign = 1
torque_sign = {torque_sign}

[points]
file = "points.csv"
''')
    return speed, torque


def test_signed_torque_point_table(tmp_path):
    speed, torque = _signed_table(tmp_path / "c", '"signed"')
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = read_points(tmp_path / "store").sort_values("point_id")
    assert pts.speed_rpm.tolist() == speed.tolist() and pts.torque_nm.tolist() == torque.tolist()
    assert pts.quadrant.tolist() == ["motor", "motor", "generator", "generator"]


def test_negative_drum_torque_in_a_table_is_refused(tmp_path):
    _signed_table(tmp_path / "c", "1")
    with pytest.raises(InputError) as exc:
        ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    assert "points.csv" in str(exc.value) and "2 of 4" in str(exc.value)


def test_time_of_day_needs_the_session_date(tmp_path):
    make_german_logger(tmp_path / "c")
    toml = tmp_path / "c" / "logger_de" / "session.toml"
    toml.write_text("\n".join(ln for ln in toml.read_text().splitlines()
                              if not ln.startswith("date")))
    with pytest.raises(InputError) as exc:
        ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    assert exc.value.column == "date" and "time of day" in str(exc.value)
