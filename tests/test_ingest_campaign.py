"""Ingest the committed synthetic campaign (raw_measurements/, written by ``bench synth``)
and check what is recovered against its ``truth.json``: every good setpoint accepted once,
every faulty one rejected for its reason, the torque-flange zero offset found from the tare."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bench.ingest.pipeline import ingest
from bench.ingest.summary import format_summary
from bench.store.manifest import read_manifest
from bench.store.read import read_points, read_rejected

CAMPAIGN = Path(__file__).resolve().parents[1] / "raw_measurements"

#: the reason ingest must give for each fault bench synth puts on a setpoint
EXPECTED_REASON = {"brake hunting": "speed unstable", "torque drift": "torque unstable",
                   "stepped early": "too short"}


@pytest.fixture(scope="module")
def ingested(tmp_path_factory):
    truth = json.loads((CAMPAIGN / "truth.json").read_text())
    store = tmp_path_factory.mktemp("store")
    ingest([CAMPAIGN], store, progress=False)
    return truth, read_points(store), read_manifest(store), read_rejected(store)


def _segment(truth_points: pd.DataFrame, t_start, t_end) -> np.ndarray:
    """Index of the setpoint (step to next step) holding the middle of each window."""
    mid = 0.5 * (np.asarray(t_start) + np.asarray(t_end))
    k = np.searchsorted(truth_points.t_step_s.to_numpy(), mid) - 1
    assert (k >= 0).all(), "a window inside the tare"
    assert (mid < truth_points.t_end_s.to_numpy()[k]).all()
    return k


def _offset_bound_nm(truth, info) -> float:
    """4 sigma of the median of the tare's samples (1.2533 sigma / sqrt(n) for Gaussian
    noise), with the flange's noise seen from the drum; n counts all but the last second
    of the standstill (the drive may start moving within it)."""
    gear = truth["gear_ratio"] if info["measured_side"] == "motor" else 1.0
    sigma = truth["instruments"]["torque_noise_nm"] * gear
    n = (info["tare"]["t_end_s"] - 1.0) * truth["instruments"]["daq_rate_hz"]
    return 4.0 * 1.2533 * sigma / np.sqrt(n)


def _matched(truth_points: pd.DataFrame, got: pd.DataFrame) -> pd.DataFrame:
    """The truth window holding the middle of each detected window."""
    mid = 0.5 * (got.t_start_s.to_numpy() + got.t_end_s.to_numpy())
    k = np.searchsorted(truth_points.t_start_s.to_numpy(), mid) - 1
    assert (k >= 0).all()
    assert (mid < truth_points.t_end_s.to_numpy()[k]).all(), "window outside every true window"
    assert len(set(k.tolist())) == len(k), "two windows in one true window"
    return truth_points.iloc[k].reset_index(drop=True)


def test_points_per_session_and_quadrant(ingested):
    truth, pts, man, _ = ingested
    for sid, t in truth["sessions"].items():
        got = pts[pts.session_id == sid]
        # every good operating point the bench visited is found once, none invented
        n_good = t.get("n_good_points", t["n_points"])
        assert len(got) == n_good, sid
        assert (got.quadrant == t["mode"]).all(), sid
        assert man["sessions"][sid]["points_per_quadrant"][t["mode"]] == n_good
    # the paper's campaigns: more than 500 points in each mode
    assert (pts.quadrant == "motor").sum() > 500 and (pts.quadrant == "generator").sum() > 500


def test_faulty_setpoints_rejected_for_their_reason(ingested):
    truth, pts, man, rej = ingested
    for sid, t in truth["sessions"].items():
        if t["kind"] != "timeseries":
            continue
        tp = pd.DataFrame(t["points"])
        bad = tp[tp.fault != ""]
        assert 0.01 <= len(bad) / len(tp) <= 0.03, sid  # a few per session: 1-3 %
        r = rej[rej.session_id == sid]
        k = _segment(tp, r.t_start_s, r.t_end_s)
        # exactly one rejected window per faulty setpoint, none elsewhere
        assert sorted(k.tolist()) == bad.index.tolist(), sid
        want = [EXPECTED_REASON[f] for f in tp.fault.to_numpy()[k]]
        assert r.reason.tolist() == want, sid
        # and no accepted window on a faulty setpoint
        got = pts[pts.session_id == sid]
        assert (tp.fault.to_numpy()[_segment(tp, got.t_start_s, got.t_end_s)] == "").all()
        counts = pd.Series(want).value_counts().to_dict()
        assert man["sessions"][sid]["rejected"] == counts, sid
    summary = format_summary(sorted(man["sessions"]), [], man)
    total = rej.reason.value_counts()
    assert ", ".join(f"{r}: {n}" for r, n in sorted(total.items())) in summary


def test_torque_zero_offset_from_the_tare(ingested):
    truth, _, man, _ = ingested
    for sid, t in truth["sessions"].items():
        e = man["sessions"][sid]
        if t["kind"] != "timeseries":
            # an averaged table has no standstill samples: nothing subtracted, and said so
            assert e["torque_zero_offset_nm"] is None and e["torque_zero_note"]
            continue
        assert e["torque_zero_offset_nm"] == pytest.approx(
            t["torque_zero_offset_drum_nm"], abs=_offset_bound_nm(truth, t)), sid
        # the samples used lie in the true standstill, at least 1 s of them
        tare = e["torque_zero_tare"]
        assert t["tare"]["t_start_s"] <= tare["t_start_s"] < tare["t_end_s"] <= t["tare"]["t_end_s"]
        assert tare["t_end_s"] - tare["t_start_s"] >= 1.0


def test_timeseries_points_match_truth(ingested):
    truth, pts, man, _ = ingested
    for sid, t in truth["sessions"].items():
        if t["kind"] != "timeseries":
            continue
        got = pts[pts.session_id == sid].sort_values("point_id").reset_index(drop=True)
        want = _matched(pd.DataFrame(t["points"]), got)
        assert (want.fault == "").all()
        # speed noise 0.4 rpm (+0.1 %) per sample, >= 150 samples a window: 1 rpm is > 10 sigma
        # of the mean; a window starting a little earlier than the truth's adds < 0.2 rpm
        np.testing.assert_allclose(got.speed_rpm, want.speed_rpm, atol=1.0)
        # torque: ingest subtracted the flange zero offset it found in the tare. Window
        # means: 0.06 N m noise at the flange (x3 seen from the drum for motor_02) over
        # >= 150 samples, 0.05 N m is > 3 sigma; plus the tare estimate's 4-sigma bound,
        # an error shared by all points of the session
        bound = _offset_bound_nm(truth, t)
        np.testing.assert_allclose(got.torque_nm, want.torque_nm, atol=0.05 + bound)
        # that shared error is the offset estimate's and nothing else (+-0.01 N m: the
        # noise of a mean over >= 256 windows)
        err = man["sessions"][sid]["torque_zero_offset_nm"] - t["torque_zero_offset_drum_nm"]
        assert np.mean(want.torque_nm - got.torque_nm) == pytest.approx(err, abs=0.01), sid
        # analyzer noise + 1 W quantisation over >= 40 records: 10 W = 0.12 % of 8.2 kW,
        # an order of magnitude below the 1.6 % fit residual the points feed
        np.testing.assert_allclose(got.p_elec_w, want.p_elec_w, atol=10.0)


def test_clock_offset_and_drift(ingested):
    truth, _, man, _ = ingested
    for sid, t in truth["sessions"].items():
        if t["kind"] != "timeseries":
            continue
        c, e = t["clock"], man["sessions"][sid]
        # ingest models the records as interval means; what remains is the analyzer's
        # filter lag (reading delay minus half the 0.1 s interval), by which the data
        # align later than the clock; 20 ms for noise. The header prior is seconds off.
        lag = c["power_reading_delay_s"] - 0.05
        assert c["offset_s"] - lag - 0.02 <= e["clock_offset_s"] <= c["offset_s"] + 0.02, sid
        assert e["clock_offset_prior_s"] == pytest.approx(c["header_offset_s"], abs=1e-3)
        # a line through 8 segment offsets good to ~10 ms each over ~1900 s: 15 ppm; the
        # truth lies within 3 of the estimate's stated standard uncertainties
        sigma = e["clock_drift_uncertainty_ppm"]
        assert abs(e["clock_drift_estimate_ppm"] - c["drift_ppm"]) <= max(3 * sigma, 15.0), sid
        if "clock_drift_note" in e:  # not resolved (below 2 sigma): offset only, said so
            assert e["clock_drift_ppm"] == 0.0 and abs(e["clock_drift_estimate_ppm"]) <= 2 * sigma
            assert "offset only" in e["clock_drift_note"]
        else:
            assert e["clock_drift_ppm"] == pytest.approx(c["drift_ppm"], abs=15.0), sid


def test_point_table_session(ingested):
    truth, pts, _, _ = ingested
    for sid, t in truth["sessions"].items():
        if t["kind"] != "operating_points":
            continue
        got = pts[pts.session_id == sid].sort_values("point_id").reset_index(drop=True)
        want = pd.DataFrame(t["points"])
        assert (got.source == "operating_point_table").all()
        # the table's means carry averaging noise and the flange zero offset: a table
        # has no tare, so ingest cannot remove it
        np.testing.assert_allclose(got.speed_rpm, want.speed_rpm, atol=1.0)
        np.testing.assert_allclose(got.torque_nm - t["torque_zero_offset_drum_nm"],
                                   want.torque_nm, atol=0.05)
        np.testing.assert_allclose(got.p_elec_w, want.p_elec_w, atol=10.0)


def test_drive_rating_recorded_from_drive_toml(ingested):
    # raw_measurements/drive.toml (bench synth) states the paper's drive: docs/paper_figures.md §1,
    # 8.2 kW, |speed| <= 1500 rpm, torque <= 78 N m; every session records it
    truth, _, man, _ = ingested
    for sid in truth["sessions"]:
        drive = man["sessions"][sid]["drive"]
        assert (drive["nominal_power_w"], drive["max_speed_rpm"], drive["max_torque_nm"]) == (
            8200.0, 1500.0, 78.0)
        assert drive["sources"] == dict.fromkeys(
            ("nominal_power_w", "max_speed_rpm", "max_torque_nm"), "drive.toml")
        assert "Stuyts" in drive["source"]
        assert "campaign/drive.toml" in man["sessions"][sid]["files"]
