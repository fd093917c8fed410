"""Slow (1 Hz) logs: every held setpoint is a point or a rejected window, and a clock drift
the data cannot resolve falls back to the offset alone, saying so."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from ingest_fixtures import make_timeseries_session
from stream_fixtures import cut_analyzer, cut_daq, make_counted_log, make_german_logger

from bench.ingest.align import drift_line
from bench.ingest.pipeline import ingest
from bench.store.manifest import kind_files


def _stored(store, sid):
    pts = pd.read_parquet(kind_files(store, "points")[sid])
    rej = pd.read_parquet(kind_files(store, "rejected")[sid])
    return pts, rej


@pytest.mark.parametrize("noisy", [3, 7])
def test_every_hold_of_a_1hz_log_is_a_point_or_a_rejected_window(tmp_path, noisy):
    truth = make_german_logger(tmp_path / "c", noisy_hold=noisy)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts, rej = _stored(tmp_path / "store", "logger_de")
    # the log's clock starts at the first row; holds start every hold_s from there; the
    # fixture leaves out 12 s in the middle of hold 2 and 25 s around the step to hold 6
    step, hold = truth.step_s, truth.hold_s
    gaps = [(step[2] + hold / 2 - 6, step[2] + hold / 2 + 6), (step[6] - 10, step[6] + 15)]
    for k, start in enumerate(step):
        t = np.arange(start + 2.0, start + hold - 2.0) + 0.5  # the hold without its steps
        t = t[~np.any([(t >= a) & (t < b) for a, b in gaps], axis=0)]
        covered = np.zeros(t.size, bool)
        for frame in (pts, rej):
            for a, b in zip(frame["t_start_s"], frame["t_end_s"], strict=True):
                covered |= (t >= a) & (t <= b)
        assert covered.mean() >= 0.9, (k, covered.mean())
    # the noisy hold (12 rpm speed scatter, 12 x the session's) is one window, with its reason
    start = truth.step_s[noisy]
    mine = rej[(rej["t_end_s"] > start) & (rej["t_start_s"] < start + truth.hold_s)]
    assert mine["reason"].tolist() == ["speed unstable"]
    assert mine["t_end_s"].item() - mine["t_start_s"].item() >= 0.8 * truth.hold_s
    assert not ((pts["t_end_s"] > start + 2) & (pts["t_start_s"] < start + truth.hold_s)).any()


def test_1hz_clocks_with_a_known_drift_fall_back_to_the_offset(tmp_path):
    setpoints = [(s, q) for s in (300.0, 600.0, 900.0, 1200.0) for q in (10.0, 30.0, 50.0, 70.0)]
    truth = make_timeseries_session(tmp_path / "c", setpoints=setpoints, hold_s=30.0,
                                    daq_hz=1.0, analyzer_hz=1.0, drift_ppm=37.0, markers=False)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    e = json.loads((tmp_path / "store" / "manifest.json").read_text())["sessions"]["motor_01"]
    sigma = e["clock_drift_uncertainty_ppm"]
    # 37 ppm over 480 s is 18 ms: a 1 s grid cannot resolve it; the stated uncertainty says
    # so (hundreds of ppm), the truth lies within 3 of them, and the drift used is 0
    assert sigma > 100.0
    assert abs(e["clock_drift_estimate_ppm"] - truth.drift_ppm) <= 3 * sigma
    assert e["clock_drift_ppm"] == 0.0
    assert "offset only" in e["clock_drift_note"] and "not resolved" in e["clock_drift_note"]
    # the offset alone: within a fifth of the 1 s sample interval
    assert e["clock_offset_s"] == pytest.approx(truth.offset_s, abs=0.2)
    pts, _ = _stored(tmp_path / "store", "motor_01")
    assert len(pts) == len(setpoints)  # every hold a point
    got = pts.sort_values("t_start_s")[["speed_rpm", "torque_nm"]].to_numpy()
    # window means of 1 rpm / 0.15 N m noise over ~25 samples, the torque tare subtracted
    np.testing.assert_allclose(got[:, 0], np.array(setpoints)[:, 0], atol=3.0)
    np.testing.assert_allclose(got[:, 1], np.array(setpoints)[:, 1], atol=0.5)


def test_drift_line_slope_error_is_the_ols_standard_error():
    rng = np.random.default_rng(5)
    t = np.linspace(100.0, 1900.0, 8)
    y = 1.3 + 40e-6 * t + rng.normal(0, 0.02, t.size)
    slope, intercept, sigma = drift_line(t, y, floor_s=0.001)
    ols = sm.OLS(y, sm.add_constant(t)).fit()
    assert slope == pytest.approx(ols.params[1], rel=1e-9)
    assert intercept == pytest.approx(ols.params[0], rel=1e-9)
    assert sigma == pytest.approx(ols.bse[1], rel=1e-9)
    # two segments: no residual to judge by, the floor sets it: sqrt(floor^2 / Sxx)
    _, _, sigma2 = drift_line([0.0, 1000.0], [1.0, 1.04], floor_s=0.01)
    assert sigma2 == pytest.approx(0.01 / np.sqrt(2 * 500.0**2), rel=1e-12)


def _write_stamped_log(root, ampm: bool, rows_per_s: int = 4):
    """A log stamped in whole seconds (12-hour clock) at ``rows_per_s`` rows per second,
    with the columns ``Date/Time``, ``Speed [rpm]``, ``Torque [Nm]``, ``Power [W]``."""
    from datetime import datetime, timedelta

    from stream_fixtures import _session_toml, _signals, german_setpoints, p_elec_w

    rng = np.random.default_rng(4)
    t, speed, torque, pe, s_set, q_set, step = _signals(german_setpoints(), 30.0,
                                                       float(rows_per_s), rng,
                                                       noise=(1.0, 0.15, 6.0))
    start = datetime(2024, 3, 5, 11, 58, 40)  # through noon: 11:59:59 AM -> 12:00:00 PM
    fmt = "%I:%M:%S %p" if ampm else "%H:%M:%S"
    rows = ["Date/Time,Speed [rpm],Torque [Nm],Power [W]"]
    rows += [f"{(start + timedelta(seconds=float(np.floor(x)))):{fmt}},{s:.2f},{q:.3f},{p:.1f}"
             for x, s, q, p in zip(t, speed, torque, pe, strict=True)]
    folder = root / "stamped"
    folder.mkdir(parents=True)
    (folder / "log.csv").write_text("\n".join(rows) + "\n")
    _session_toml(folder, "stamped", "1", (3000.0, 100.0, 15000.0))
    return s_set, q_set, p_elec_w(s_set, q_set)


@pytest.mark.parametrize("ampm", [True, False])
def test_whole_second_stamps_at_4hz_are_spread_and_named_columns_found(tmp_path, ampm):
    speed, torque, p_elec = _write_stamped_log(tmp_path / "c", ampm)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)  # no mapping.toml
    e = json.loads((tmp_path / "store" / "manifest.json").read_text())["sessions"]["stamped"]
    assert e["timing"]["stamp_rows_spread"] == 4
    assert e["timing"]["sample_interval_s"] == pytest.approx(0.25)
    cols = e["instruments"]["log"]["columns"]
    assert cols["time"]["column"] == "Date/Time" and cols["p_elec"]["column"] == "Power [W]"
    pts, _ = _stored(tmp_path / "store", "stamped")
    pts = pts.sort_values("t_start_s")
    assert len(pts) == len(speed)  # every hold, the one through noon included
    # holds start every 30 s on the logger's clock: the spread keeps them there
    k = np.arange(len(speed))
    assert np.all((pts["t_start_s"] >= 30 * k - 1) & (pts["t_end_s"] <= 30 * (k + 1) + 1))
    np.testing.assert_allclose(pts["speed_rpm"], speed, atol=1.0)
    np.testing.assert_allclose(pts["torque_nm"], torque, atol=0.2)
    np.testing.assert_allclose(pts["p_elec_w"], p_elec, rtol=0.01, atol=10.0)


def test_a_duplicated_row_of_a_1hz_log_is_still_an_error(tmp_path, capsys):
    from drivebench.cli import main

    make_german_logger(tmp_path / "c")
    log = tmp_path / "c" / "logger_de" / "log.csv"
    lines = log.read_text(encoding="cp1252").splitlines()
    lines.insert(40, lines[40])
    log.write_text("\n".join(lines) + "\n", encoding="cp1252")
    rc = main(["ingest", str(tmp_path / "c"), "--store", str(tmp_path / "s"), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2 and "time repeats" in err and "log.csv:42" in err, err  # the second copy


def test_holds_the_analyzer_did_not_record_are_rejected_windows(tmp_path):
    # a 1 Hz logger and a 1 Hz analyzer; the analyzer starts late (its first 75 s, the
    # first two holds and a bit, are cut off) and misses 50 s in the middle (holds 6-7)
    setpoints = [(s, q) for s in (300.0, 600.0, 900.0, 1200.0) for q in (10.0, 30.0, 50.0, 70.0)]
    truth = make_timeseries_session(tmp_path / "c", setpoints=setpoints, hold_s=30.0,
                                    daq_hz=1.0, analyzer_hz=1.0, drift_ppm=0.0, markers=False)
    cut = [(0.0, 75.0), (200.0, 250.0)]  # analyzer clock [s]
    cut_analyzer(tmp_path / "c" / "motor_01" / "analyzer.csv", cut)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts, rej = _stored(tmp_path / "store", "motor_01")
    missing = rej[rej["reason"] == "no analyzer samples"]
    # the truth: holds k span [step_k, step_k+1) on the DAQ clock; the analyzer's clock
    # is offset by truth.offset_s
    steps = list(truth.step_times_s) + [truth.step_times_s[-1] + 30.0]
    gaps = [(a + truth.offset_s, b + truth.offset_s) for a, b in cut]
    fully_unrecorded = []
    for k in range(len(setpoints)):
        lo, hi = steps[k] + 3.0, steps[k + 1] - 1.0  # the hold without its transitions
        unrecorded = [(max(lo, a), min(hi, b)) for a, b in gaps if min(hi, b) - max(lo, a) > 2]
        point = ((pts["t_start_s"] < hi) & (pts["t_end_s"] > lo)).sum()
        if point:  # a setpoint recorded in part is that part's point, and one only
            assert point == 1, k
            continue
        assert unrecorded, k  # recorded holds are points, as before
        fully_unrecorded.append(k)
        for a, b in unrecorded:  # the setpoint is a rejected window, with its reason
            mine = missing[(missing["t_start_s"] <= a + 3.0) & (missing["t_end_s"] >= b - 3.0)]
            assert len(mine) == 1, (k, a, b, missing)
    # holds 0 and 1 lie before the analyzer's record, hold 7 in its gap (hold 6 keeps the
    # 4 s the analyzer recorded before its gap as a point)
    assert fully_unrecorded == [0, 1, 7]
    # no window claims an unrecorded stretch (beyond one record's 1 s averaging
    # interval), and the accounting counts them
    for a, b in gaps:
        assert not ((pts["t_start_s"] < b - 1.0) & (pts["t_end_s"] > a + 1.0)).any()
    e = json.loads((tmp_path / "store" / "manifest.json").read_text())["sessions"]["motor_01"]
    # one reason, counted together (the window's times are its t_start_s, t_end_s)
    assert e["rejected"]["no analyzer samples"] == len(missing) == 3


def test_holds_the_logger_did_not_log_are_rejected_windows(tmp_path):
    # the other way round: the analyzer records throughout, the 1 Hz DAQ misses 100 s
    # (holds 6, 7 and 8 whole, the end of hold 5 and the start of hold 9)
    setpoints = [(s, q) for s in (300.0, 600.0, 900.0, 1200.0) for q in (10.0, 30.0, 50.0, 70.0)]
    truth = make_timeseries_session(tmp_path / "c", setpoints=setpoints, hold_s=30.0,
                                    daq_hz=1.0, analyzer_hz=1.0, drift_ppm=0.0, markers=False)
    cut_daq(tmp_path / "c" / "motor_01" / "daq.csv", [(190.0, 290.0)])
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts, rej = _stored(tmp_path / "store", "motor_01")
    unlogged = rej[rej["reason"] == "no logger samples"]
    steps = list(truth.step_times_s) + [truth.step_times_s[-1] + 30.0]
    for k in (6, 7, 8):  # each unlogged hold is one rejected window, with its reason
        lo, hi = steps[k] + 3.0, steps[k + 1] - 1.0
        mine = unlogged[(unlogged["t_start_s"] <= lo) & (unlogged["t_end_s"] >= hi)]
        assert len(mine) == 1, (k, unlogged)
        r = mine.iloc[0]
        assert steps[k] - 1.0 <= r["t_start_s"] and r["t_end_s"] <= steps[k + 1] + 1.0
    assert len(unlogged) == 3  # holds 5 and 9 are points where the DAQ logged them
    assert len(pts) == len(setpoints) - 3
    e = json.loads((tmp_path / "store" / "manifest.json").read_text())["sessions"]["motor_01"]
    assert e["rejected"]["no logger samples"] == 3


@pytest.mark.parametrize("form", ["stamp_plus_counter", "counter_alone"])
def test_a_sample_counter_places_rows_of_repeated_stamps(tmp_path, form):
    # a 4 Hz logger stamping whole seconds that drops every 7th row: a stamp then holds
    # 3 rows whose places an even spread cannot know; its sample counter (the row within
    # the stamp, or a running count) gives them
    t = make_counted_log(tmp_path / "c", form)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    samples = pd.read_parquet(kind_files(tmp_path / "store", "samples")["counted"])
    # the truth: each row's own time since the first row, exactly (quarter seconds)
    np.testing.assert_allclose(np.sort(samples["time_s"].to_numpy()), t - t[0], atol=1e-9)
    e = json.loads((tmp_path / "store" / "manifest.json").read_text())["sessions"]["counted"]
    assert "stamp_rows_spread" not in e["timing"]
    assert e["timing"]["sample_interval_s"] == pytest.approx(0.25)
    pts, _ = _stored(tmp_path / "store", "counted")
    assert len(pts) == 4


def test_a_bad_sample_counter_entry_names_what_it_needs(tmp_path):
    from bench.ingest.mapping import load_mapping
    from kernel.errors import InputError

    path = tmp_path / "mapping.toml"
    path.write_text('[log.columns.sample_counter]\ncolumn = "Sample"\n')
    with pytest.raises(InputError, match="positive 'rate_hz'"):
        load_mapping(path)
