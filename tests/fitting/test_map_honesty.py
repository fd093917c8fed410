"""The map passes through what was measured, and outliers are flagged, not hidden: a hobby
dyno table whose peak efficiency lies at part load and that holds one glitch row
(bench.synth.exports.make_hobby_dyno_table)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from statsmodels.stats.outliers_influence import OLSInfluence

from bench.ingest.pipeline import ingest
from bench.store.read import read_points
from bench.synth.exports import make_hobby_dyno_table
from fitting.cli import format_summary
from fitting.pipeline import FitOptions, run_fit
from fitting.power_fit import fit_power_model, outlier_test
from fitting.terms import PAPER_TERMS


@pytest.fixture(scope="module")
def dyno_fit(tmp_path_factory):
    root = tmp_path_factory.mktemp("dyno")
    truth = make_hobby_dyno_table(root / "c")
    ingest([root / "c"], root / "store", progress=False)
    summary = run_fit(root / "store", root / "fit", FitOptions(), progress=False)
    return truth, read_points(root / "store"), summary, root / "fit"


def test_ceiling_is_never_below_a_measured_point(dyno_fit):
    truth, pts, summary, fit = dyno_fit
    # independent truth: the highest efficiency of the written rows outside the masking
    # rules' near-axis band (2 % of the nominal power, here the largest |omega*T|)
    p_mech = truth["speed_rpm"] * truth["torque_nm"] * 2 * np.pi / 60
    nominal = summary["drive"]["nominal_power_w"]
    assert nominal == pytest.approx(np.max(p_mech), rel=1e-6)
    ok = (p_mech >= 0.02 * nominal) & (truth["p_elec_w"] >= 0.02 * nominal)
    eta = p_mech / truth["p_elec_w"]
    top = float(np.max(eta[ok]))
    k = int(np.flatnonzero(ok)[np.argmax(eta[ok])])
    assert truth["speed_rpm"][k] >= 2000 and truth["torque_nm"][k] < 2.0  # part load of 6 N m
    peak = summary["efficiency"]["peak"]["motor"]
    assert peak["measured"]["eta"] == pytest.approx(top, abs=2e-5)  # the file's rounding
    c = peak["ceiling"]
    assert c["eta_max_measured"] == pytest.approx(top, abs=2e-5)
    # its uncertainty: no std in the table, so 0.2 % of each power: sqrt(2) * 0.2 % of eta
    assert c["noise_eta"] == pytest.approx(np.sqrt(2) * 0.002 * top, rel=1e-3)
    assert c["eta"] >= top
    # the map peak is the measured peak within that uncertainty, not a lower clipped value
    assert abs(peak["map"]["eta"] - top) <= c["noise_eta"]
    assert summary["efficiency"]["points_against_map"]["motor"]["n_above_map"] == 0
    emap = pd.read_parquet(fit / "efficiency_map.parquet")
    assert (emap["status"] == "clipped").sum() < 0.01 * emap["status"].isin(("ok",)).sum()


def test_the_glitch_row_is_flagged_and_the_fit_without_it_shown(dyno_fit):
    truth, pts, summary, _ = dyno_fit
    out = summary["statistics"]["outliers"]
    assert out["n_flagged"] == 1
    flagged = out["points"][0]
    row = truth["outlier_row"]
    assert flagged["point_id"] == row
    assert flagged["speed_rpm"] == pytest.approx(1811.0)
    assert flagged["p_elec_w"] == pytest.approx(322.0)
    # the refit without it: the drive's true losses have no point like it, so the residual
    # RMS falls to the rows' noise (0.5 W written, plus the eq. 4 model's misfit of this
    # loss shape, a few W) from ~17 W with it
    without = out["without"]
    assert without["n_points"] == len(pts) - 1
    assert without["residuals"]["rmse_w"] < 5.0 < summary["statistics"]["residuals"]["all"][
        "rmse_w"]
    assert "1 outlier point(s)" in " ".join(summary["notes"])
    text = format_summary(summary, "fit")
    assert "outlier" in text and "1811 rpm, 0.0004 N m, 322 W" in text
    assert json.loads(json.dumps(summary))  # strict JSON


def test_studentized_residuals_match_statsmodels():
    rng = np.random.default_rng(3)
    speed = rng.uniform(-1500, 1500, 80)
    torque = rng.uniform(1, 78, 80)
    p = 300 + 4e-4 * speed**2 + 0.07 * torque**2 + 0.108 * speed * torque + rng.normal(0, 20, 80)
    p[17] += 400.0  # one outlier: 20 noise sigmas
    fit = fit_power_model(speed, torque, p, PAPER_TERMS, nominal_power_w=8200.0)
    x = np.column_stack([speed**i * torque**j for i, j in PAPER_TERMS])
    ref = OLSInfluence(sm.OLS(p, x).fit()).resid_studentized_external
    np.testing.assert_allclose(fit.studentized, ref, rtol=1e-8)
    flagged, critical = outlier_test(fit)
    assert np.flatnonzero(flagged).tolist() == [17]
    # statsmodels' own Bonferroni outlier test agrees on which points are outliers
    bonf = sm.OLS(p, x).fit().outlier_test(method="bonf")[:, 2]
    assert np.flatnonzero(bonf < 0.05).tolist() == [17]
    assert 3.0 < critical < 4.0


def test_fit_peak_line_keeps_small_torques():
    summary = {"statistics": {"n_points": 1, "points_per_quadrant": {}, "method": "m",
                              "coefficients": [], "residuals": {"all": {
                                  "mean_w": 0, "std_w": 0, "std_pct_nominal": 0,
                                  "max_abs_w": 0, "max_abs_pct_nominal": 0}},
                              "r2": 1.0, "normality": {}, "selection": {
                                  "reason": "r", "exported": "e", "exported_because": "b"}},
               "model": {"name": "m", "sha256": "0" * 64}, "notes": [],
               "drive": {"nominal_power_w": 1, "max_speed_rpm": 1, "max_torque_nm": 1,
                         "source": "s"},
               "selection_table": [], "extra_terms_check": {}, "outputs": [],
               "efficiency": {"band_shares": [], "peak": {"motor": {"map": {
                   "eta": 0.5, "speed_rpm": 2125.0, "torque_nm": 0.32}}}}}
    assert "at 2125 rpm, 0.32 N m (map)" in format_summary(summary, "out")


@pytest.mark.parametrize("shift", [0.0, 0.03])
def test_repeatability_of_two_sessions_at_the_same_setpoints(shift):
    from fitting.efficiency import MaskingRules
    from fitting.repeatability import repeatability

    speed = np.repeat([500.0, 1000.0, 1500.0], 4)
    torque = np.tile([20.0, 40.0, 60.0, 78.0], 3)
    p_mech = speed * torque * 2 * np.pi / 60
    p_elec = p_mech + 300 + 0.05 * torque**2
    frame = pd.DataFrame({
        "session_id": ["a"] * 12 + ["b"] * 12,
        "speed_rpm": np.concatenate([speed, speed + 2.0]),  # 2 rpm apart: one setpoint
        "torque_nm": np.concatenate([torque, torque]),
        "p_mech_w": np.concatenate([p_mech, (speed + 2.0) * torque * 2 * np.pi / 60]),
        "p_elec_w": np.concatenate([p_elec, p_elec * (1 + shift)]),
        "quadrant": "motor"})
    out = repeatability(frame, MaskingRules(8200.0))
    assert out["n_pairs"] == 12  # each setpoint once, across the sessions only
    # a 3 % higher p_elec lowers eta by ~3 % (> 2 x sqrt(2) x 0.28 % combined u); the
    # 2 rpm offset alone changes eta by < 0.2 % (within it)
    assert out["n_disagreeing"] == (12 if shift else 0)
    assert ("note" in out) == bool(shift)
