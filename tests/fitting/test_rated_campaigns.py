"""Campaigns with a known truth through ingest and fit: single quadrant, a 150 kW drive.

``bench.synth.rated_drive`` writes operating-point-table sessions of a drive with a
power-limited (non-convex) envelope and its ``drive.toml``; ingest and fit must
recover every point, take the rating from the campaign, and draw a map that stays
inside the true envelope with a peak near the truth's.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from bench.ingest.pipeline import ingest
from bench.store.read import read_points
from bench.synth.rated_drive import EV_DRIVE, PAPER_DRIVE, grid_points, write_table_campaign
from fitting.model_file import load_power_model
from fitting.pipeline import FitOptions, run_fit

CASES = {
    # drive, quadrants, P_elec noise [W], tolerance of the true peak [-]
    "motor only": (PAPER_DRIVE, ("motor",), 40.0, 0.02),
    "150 kW": (EV_DRIVE, ("motor", "generator"), 300.0, 0.01),
}


@pytest.mark.parametrize("case", list(CASES))
def test_rated_campaign(tmp_path, case):
    drive, quadrants, noise_w, tol = CASES[case]
    pts = grid_points(drive, quadrants, noise_w=noise_w, seed=7)
    write_table_campaign(tmp_path / "campaign", drive, pts)
    ingest([tmp_path / "campaign"], tmp_path / "store", progress=False)
    stored = read_points(tmp_path / "store")
    # every written point recovered once, in its quadrant, power to the file's rounding
    # (P_el in kW with 6 decimals: 1 mW)
    for q in quadrants:
        assert (stored["quadrant"] == q).sum() == (pts["quadrant"] == q).sum()
    merged = stored.merge(pts, on=["session_id", "point_id"], suffixes=("", "_written"))
    np.testing.assert_allclose(merged["p_elec_w"], merged["p_elec_w_written"], atol=1e-3)

    summary = run_fit(tmp_path / "store", tmp_path / "fit", FitOptions(), progress=False)
    model = load_power_model(tmp_path / "fit" / "power_model.json")
    assert model.drive.nominal_power_w == drive.rating.nominal_power_w
    assert model.drive.max_speed_rpm == drive.rating.max_speed_rpm
    assert set(model.domain) == set(quadrants)
    # residual std recovers the noise: the eq. 4 model misses part of this loss shape, so
    # only a bound (noise <= std <= 2 x noise)
    std = model.statistics["residuals"]["all"]["std_w"]
    assert 0.9 * noise_w <= std <= 2.0 * noise_w

    emap = pd.read_parquet(tmp_path / "fit" / "efficiency_map.parquet")
    for q in quadrants:
        shown = emap[(emap["quadrant"] == q) & emap["status"].isin(("ok", "clipped"))]
        assert len(shown) > 1000
        # no node above the true envelope (chords between measured tops lie below it)
        top = drive.rating.largest_torque_nm(shown["speed_rpm"])
        assert not (shown["torque_nm"] > top + 1e-9).any()
        peak = summary["efficiency"]["peak"][q]
        truth = float(np.nanmax(drive.eta(shown["speed_rpm"], shown["torque_nm"])))
        # the map keeps the true peak (within the interpolation between set points) ...
        assert peak["map"]["eta"] >= truth - tol
        # ... and shows what was measured: the highest efficiency of the written points
        # (noisy: a part-load point's noise in eta is large, and the table states no std),
        # within that point's uncertainty (0.2 % of each power: sqrt(2) * 0.2 % of eta)
        floor = 0.02 * drive.rating.nominal_power_w  # the masking rules' near-axis limit
        mine = ((pts["quadrant"] == q) & (pts["p_mech_w"].abs() >= floor)
                & (pts["p_elec_w"].abs() >= floor)).to_numpy()
        eta_w = np.where(pts["p_mech_w"] > 0, pts["p_mech_w"] / pts["p_elec_w"],
                         pts["p_elec_w"] / pts["p_mech_w"])[mine]
        top = float(np.max(eta_w[eta_w <= 1.0]))
        assert peak["measured"]["eta"] == pytest.approx(top, abs=1e-5)  # the file's rounding
        assert abs(peak["map"]["eta"] - top) <= np.sqrt(2) * 0.002 * top + 1e-9
        assert peak["map"]["eta"] <= peak["ceiling"]["eta"] + 1e-12


def test_bench_fit_checks_the_points_against_the_envelope_drive_toml_states(tmp_path):
    """The 150 kW drive's points lie on and under its true envelope (constant power above
    4000 rpm). A drive.toml that states a base speed of 3000 rpm puts every point above
    min(T_max, T_max 3000 / |n|) + 1 % of T_max above it: bench fit counts exactly those,
    records the envelope in power_model.json, and keeps the points; with the true base
    speed none is above."""
    from bench.store.read import read_points as stored_points
    from fitting.envelope_check import envelope_check

    drive = EV_DRIVE
    pts = grid_points(drive, ("motor", "generator"), noise_w=300.0, seed=7)
    write_table_campaign(tmp_path / "campaign", drive, pts, base_speed_rpm=3000.0)
    ingest([tmp_path / "campaign"], tmp_path / "store", progress=False)
    summary = run_fit(tmp_path / "store", tmp_path / "fit", FitOptions(), progress=False)
    model = load_power_model(tmp_path / "fit" / "power_model.json")
    assert model.drive.base_speed_rpm == 3000.0
    check = summary["statistics"]["envelope_check"]
    stored = stored_points(tmp_path / "store")
    top = np.minimum(drive.rating.max_torque_nm,
                     drive.rating.max_torque_nm * 3000.0 / stored["speed_rpm"].abs())
    expected = int((stored["torque_nm"].abs() > top + 0.01 * drive.rating.max_torque_nm).sum())
    assert expected > 10 and check["n_above"] == expected
    assert check["worst"]["speed_rpm"] != 0 and any("lie above the drive's stated" in n
                                                     for n in summary["notes"])
    assert model.statistics["n_points"] == len(stored)  # kept in the fit
    true = drive.rating  # its own base speed, 4000 rpm
    assert envelope_check(stored, true)["n_above"] == 0


@pytest.mark.parametrize("lines,key", [
    ("envelope_speed_rpm = [0, 3000, 12000]\nenvelope_torque_nm = [300, 320, 100]",
     "envelope_torque_nm"),
    ("envelope_speed_rpm = [0, 3000, 2000]\nenvelope_torque_nm = [300, 300, 100]",
     "envelope_speed_rpm"),
    ("base_speed_rpm = -5.0", "base_speed_rpm"),
    ("envelope_speed_rpm = [0, 3000]", "envelope_torque_nm"),
])
def test_a_bad_envelope_in_drive_toml_stops_ingest_naming_the_key(tmp_path, capsys, lines,
                                                                   key):
    from drivebench.cli import main

    pts = grid_points(PAPER_DRIVE, ("motor",), seed=1)
    write_table_campaign(tmp_path / "campaign", PAPER_DRIVE, pts)
    drive_file = tmp_path / "campaign" / "drive.toml"
    drive_file.write_text(drive_file.read_text() + lines + "\n")
    assert main(["ingest", str(tmp_path / "campaign"), "--store", str(tmp_path / "store")]) == 2
    err = capsys.readouterr().err
    assert "drive.toml" in err and key in err, err
    assert not (tmp_path / "store" / "manifest.json").exists()
