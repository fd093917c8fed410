"""End-to-end ingest of small synthetic sessions with a known truth (tests/ingest_fixtures.py)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from ingest_fixtures import make_points_session, make_timeseries_session, store_tree

from bench.ingest.pipeline import ingest
from bench.store.manifest import kind_files, read_manifest
from bench.store.read import read_points, read_rejected, read_samples
from drivebench.cli import main


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    root = tmp_path_factory.mktemp("camp")
    truths = {
        "motor_01": make_timeseries_session(root, "motor_01", "motor", seed=1),
        "gen_01": make_timeseries_session(root, "gen_01", "generator", locale="de", seed=2,
                                          offset_err_s=-2.4, drift_ppm=-30.0, power_unit="W"),
        "tdms_01": make_timeseries_session(root, "tdms_01", "motor", daq_format="tdms", seed=4),
    }
    table = make_points_session(root, "table_01")
    store = tmp_path_factory.mktemp("s") / "store"
    result = ingest([root], store, progress=False)
    return root, store, truths, table, result


def test_recovers_setpoints(campaign):
    _, store, truths, _, _ = campaign
    pts = read_points(store)
    for sid, truth in truths.items():
        got = pts[pts.session_id == sid].sort_values("point_id")
        # every setpoint is held 6 s and settles in < 1.5 s: one accepted window each
        assert len(got) == len(truth.setpoints), sid
        want = np.array(truth.setpoints)
        # means of >= 300 samples with 1 rpm / 0.15 N m noise: 0.3 rpm / 0.05 N m are > 5 sigma
        np.testing.assert_allclose(got.speed_rpm, want[:, 0], atol=0.3)
        np.testing.assert_allclose(got.torque_nm, want[:, 1], atol=0.05)
        # analyzer: paper quadratic + 3 W noise, >= 30 samples a window -> 2 W is > 3 sigma
        np.testing.assert_allclose(got.p_elec_w, truth.p_elec_w, atol=2.0)
        assert (got.quadrant == ("motor" if want[0, 0] > 0 else "generator")).all()
        assert (got.n_samples > 300).all()
        # std of a window is the sensor noise (1 rpm, 0.15 N m), within 20 %
        np.testing.assert_allclose(got.speed_rpm_std, 1.0, rtol=0.2)
        np.testing.assert_allclose(got.torque_nm_std, 0.15, rtol=0.2)


def test_clock_offset_matches_truth(campaign):
    _, store, truths, _, _ = campaign
    man = read_manifest(store)
    for sid, truth in truths.items():
        e = man["sessions"][sid]
        # a fifth of the 0.1 s analyzer interval: the fixture's steps are noise-free in time
        assert e["clock_offset_s"] == pytest.approx(truth.offset_s, abs=0.02), sid
        assert e["clock_offset_prior_s"] == pytest.approx(truth.prior_offset_s, abs=1e-3)


def test_samples_aligned_and_tagged(campaign):
    _, store, truths, _, _ = campaign
    s = read_samples(store, "motor_01")
    assert list(s.columns) == ["session_id", "time_s", "speed_rpm", "torque_nm", "p_mech_w",
                               "p_elec_w", "point_id", "t_winding_c", "t_housing_c",
                               "t_coolant_c", "t_ambient_c"]
    assert s.t_winding_c.isna().all()  # the fixture logs no temperature
    pts = read_points(store).query("session_id == 'motor_01'")
    # samples tagged with a point lie inside that point's window
    for _, p in pts.iterrows():
        t = s.time_s[s.point_id == p.point_id]
        assert t.min() >= p.t_start_s and t.max() < p.t_end_s
    # p_mech is speed [rad/s] * torque [N m]
    np.testing.assert_allclose(s.p_mech_w, s.speed_rpm * np.pi / 30 * s.torque_nm)
    # the overflow marker 9.91E+37 in the fixture became NaN
    assert s.speed_rpm.abs().max() < 2000
    assert s.speed_rpm.isna().sum() == 1


def test_points_table_through_mapping(campaign):
    _, store, _, table, _ = campaign
    got = read_points(store).query("session_id == 'table_01'").sort_values("point_id")
    assert (got.source == "operating_point_table").all()
    # motor side logged: drum speed = logged / 3, drum torque = logged * 3; printed to 4-5 decimals
    np.testing.assert_allclose(got.speed_rpm, table["speed_rpm"], atol=1e-3)
    np.testing.assert_allclose(got.torque_nm, table["torque_nm"], atol=1e-4)
    np.testing.assert_allclose(got.p_elec_w, table["p_elec_w"], atol=1e-3)  # kW with 6 decimals
    np.testing.assert_allclose(got.p_mech_w, table["p_mech_w"], rtol=1e-5)
    np.testing.assert_allclose(got.speed_rpm_std, 0.5 / 3)
    assert (got.n_samples == 500).all()
    assert got.t_start_s.isna().all()


def test_manifest_and_parquet_units(campaign):
    root, store, truths, _, _ = campaign
    man = json.loads((store / "manifest.json").read_text())
    e = man["sessions"]["motor_01"]
    assert set(e["files"]) == {"motor_01/session.toml", "motor_01/daq.csv",
                               "motor_01/analyzer.csv"}
    assert e["n_points"] == len(truths["motor_01"].setpoints)
    assert e["points_per_quadrant"] == {"motor": e["n_points"], "generator": 0}
    assert e["metadata"]["operator"] == "J. Doe"
    assert e["instruments"]["analyzer"]["header"]["Model"] == "WT1800"
    import pyarrow.parquet as pq

    schema = pq.read_schema(kind_files(store, "points")["motor_01"])
    assert schema.field("torque_nm").metadata == {b"unit": b"N m"}
    assert schema.field("p_elec_w").metadata == {b"unit": b"W"}
    # docs/schemas.md section 2: pandas reads the current generation's folder
    assert len(pd.read_parquet(store / man["generation"] / "points")) == sum(
        s["n_points"] for s in man["sessions"].values())
    assert read_rejected(store).columns.tolist() == ["session_id", "t_start_s", "t_end_s",
                                                     "reason"]


def test_reingest_is_byte_identical(campaign):
    root, store, _, _, _ = campaign
    before = store_tree(store)
    result = ingest([root], store, progress=False)
    assert result.ingested == [] and len(result.unchanged) == 4
    assert store_tree(store) == before


def test_changed_file_replaces_session(tmp_path):
    root = tmp_path / "camp"
    make_timeseries_session(root, "motor_01", seed=1)
    make_timeseries_session(root, "motor_02", seed=5)
    store = tmp_path / "store"
    assert main(["ingest", str(root), "--store", str(store), "--no-progress"]) == 0
    other = kind_files(store, "points")["motor_02"].read_bytes()
    old = read_manifest(store)["sessions"]["motor_01"]
    # a new file content (another seed, fewer setpoints) replaces the session
    import shutil

    shutil.rmtree(root / "motor_01")
    make_timeseries_session(root, "motor_01", seed=9, setpoints=[(500.0, 20.0), (700.0, 30.0)])
    result = ingest([root], store, progress=False)
    assert result.ingested == ["motor_01"] and result.unchanged == ["motor_02"]
    new = read_manifest(store)["sessions"]["motor_01"]
    assert new["files"] != old["files"] and new["n_points"] == 2
    assert len(read_points(store).query("session_id == 'motor_01'")) == 2
    assert kind_files(store, "points")["motor_02"].read_bytes() == other


def test_user_mapping_for_foreign_export(tmp_path):
    root = tmp_path / "camp"
    truth = make_points_session(root, "lab_b", with_mapping=False)
    store = tmp_path / "store"
    # without a mapping the foreign names are not recognised
    assert main(["ingest", str(root), "--store", str(store), "--no-progress"]) == 2
    mapping = tmp_path / "lab_b.json"
    mapping.write_text(json.dumps({"columns": {
        "speed": {"column": "n_mean", "unit": "rpm"},
        "torque": {"column": "M_mean", "unit": "N m"},
        "p_elec": {"column": "P_el", "unit": "kW"},
    }}))
    assert main(["ingest", str(root), "--store", str(store), "--mapping", str(mapping),
                 "--no-progress"]) == 0
    got = read_points(store).sort_values("point_id")
    np.testing.assert_allclose(got.p_elec_w, truth["p_elec_w"], atol=1e-3)
    assert "--mapping/lab_b.json" in read_manifest(store)["sessions"]["lab_b"]["files"]


def test_unstable_window_is_rejected_and_reported(tmp_path, capsys):
    root = tmp_path / "camp"
    truth = make_timeseries_session(root, "motor_01", hunting_hold=3)
    store = tmp_path / "store"
    assert main(["ingest", str(root), "--store", str(store), "--no-progress"]) == 0
    out = capsys.readouterr().out
    rej = read_rejected(store)
    # the hunting hold (8 rpm amplitude, std 5.7 rpm > the 3 rpm tolerance) is rejected
    assert rej.reason.tolist() == ["speed unstable"]
    t0 = truth.step_times_s[3]
    assert t0 <= rej.t_start_s[0] and rej.t_end_s[0] <= t0 + 6.0
    assert read_manifest(store)["sessions"]["motor_01"]["rejected"] == {"speed unstable": 1}
    assert len(read_points(store)) == len(truth.setpoints) - 1
    assert "speed unstable: 1" in out  # the closing summary table
    # the fixture logs no tare (it starts at 300 rpm): nothing subtracted, and the summary says so
    entry = read_manifest(store)["sessions"]["motor_01"]
    assert entry["torque_zero_offset_nm"] is None and entry["torque_zero_tare"] is None
    assert "no torque-flange tare, torque not zero-corrected: motor_01: no standstill" in out


def test_other_ingest_version_is_reingested(tmp_path):
    root = tmp_path / "camp"
    make_points_session(root, "table_01")
    store = tmp_path / "store"
    ingest([root], store, progress=False)
    man = json.loads((store / "manifest.json").read_text())
    man["sessions"]["table_01"]["ingest_version"] = 0  # as if stored by an older ingest
    (store / "manifest.json").write_text(json.dumps(man))
    assert ingest([root], store, progress=False).ingested == ["table_01"]
    assert ingest([root], store, progress=False).unchanged == ["table_01"]


def test_workers_do_not_change_the_store(campaign, tmp_path):
    root, store, _, _, _ = campaign
    one = tmp_path / "one"
    ingest([root], one, progress=False, workers=1)
    a, b = store_tree(store), store_tree(one)
    # every data file byte-identical (the manifest differs only in ingested_at and in its
    # provenance header: each ingest is its own run)
    assert {k: v for k, v in a.items() if k != "manifest.json"} == {
        k: v for k, v in b.items() if k != "manifest.json"}
    ma, mb = read_manifest(store), read_manifest(one)
    for e in (*ma["sessions"].values(), *mb["sessions"].values()):
        e.pop("ingested_at")
    assert ma.pop("provenance")["run_id"] != mb.pop("provenance")["run_id"]
    assert ma == mb
