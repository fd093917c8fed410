"""Slow (1 Hz) logs: every held setpoint is a point or a rejected window, and a clock drift
the data cannot resolve falls back to the offset alone, saying so."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from ingest_fixtures import make_timeseries_session
from stream_fixtures import make_german_logger

from bench.ingest.align import drift_line
from bench.ingest.pipeline import ingest
from bench.store import kind_files


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
