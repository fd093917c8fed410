"""``bench aep`` end to end on a synthetic optimize folder, and the band against Monte Carlo."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest
from energy_fixtures import KINDS, model_with_covariance, write_optimize_folder

from drivebench.cli import main
from energy.aep import aep_mwh
from energy.assess import assess
from energy.curve import read_optimize_run
from energy.site import Weibull


def test_band_equals_monte_carlo_over_the_coefficients(tmp_path):
    # For fixed cycles P_i = g_i . a exactly, so the AEP's spread under a ~ N(c, Sigma)
    # is the propagated sigma; 20000 draws estimate a std to about 0.5 % (tolerance 3 %).
    model = model_with_covariance()
    run = read_optimize_run(write_optimize_folder(tmp_path / "opt", model))
    site = Weibull.from_mean(2.0, 5.5)
    a = assess(run, site, "test")
    curve = run.curves["elec-lim"]
    traj = pd.read_parquet(tmp_path / "opt" / "trajectories.parquet")
    rng = np.random.default_rng(7)
    draws = rng.multivariate_normal(model.coefficients_rpm, np.array(model.covariance_rpm),
                                    20000)
    # the cycle-average power is linear in the coefficients: its row per wind speed is the
    # model with unit coefficient vectors, averaged over the cycle
    units = [dataclasses.replace(model, coefficients_rpm=tuple(e), covariance_rpm=None)
             for e in np.eye(len(model.terms))]
    rows = traj[traj["kind"] == "elec-lim"].groupby("wind_speed_m_s")
    basis = np.array([[float(np.sum(g["weight"] * u.p_elec_w(g["speed_rpm"], g["torque_nm"])))
                       for u in units] for _, g in rows])
    aeps = [aep_mwh(curve.wind_speed_m_s, p, site) for p in draws @ basis.T]
    assert a.kinds["elec-lim"].sigma_elec_model_mwh == pytest.approx(np.std(aeps), rel=0.03)
    assert a.kinds["elec-lim"].elec.aep_mwh == pytest.approx(np.mean(aeps), rel=0.01)


def test_bench_aep_writes_every_file(tmp_path, capsys):
    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance(),
                                   failed=("elec-lim-8.5",))
    out = tmp_path / "aep"
    code = main(["aep", "--optimize", str(folder), "--weibull-k", "2", "--mean-speed", "5.5",
                 "--height-m", "75", "--mean-sigma", "0.3", "--out", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "elec-lim" in text and "moved to 100 m" in text
    doc = json.loads((out / "aep.json").read_text())
    assert doc["schema"] == "drivebench.aep"
    rows = {r["kind"]: r for r in doc["kinds"]}
    assert rows["elec-lim"]["n_points"] == 4  # the failed solve is left out ...
    assert any("8.5" in n for n in doc["notes"])  # ... and said so
    assert rows["elec-lim"]["sigma_aep_elec_site_mwh"] > 0
    assert doc["nominal_power_w"] == 8200.0
    curves = pd.read_csv(out / "power_curves.csv")
    assert set(curves["kind"]) == set(KINDS)
    yaml = pytest.importorskip("yaml")
    for kind in KINDS:
        for q in ("electrical", "mechanical"):
            d = yaml.safe_load((out / "awesio" / f"{kind}_{q}.yml").read_text())
            assert d["metadata"]["schema"] == "power_curves_schema.yml"
            pts = d["power_curves"][0]["wind_speed_data"]
            col = "p_elec_w" if q == "electrical" else "p_mech_w"
            np.testing.assert_allclose([p["performance"]["power"]["average_cycle_power"]
                                        for p in pts],
                                       -curves.loc[curves["kind"] == kind, col].to_numpy(),
                                       rtol=1e-5)


@pytest.mark.parametrize(
    "site_args",
    [
        [],
        ["--weibull-k", "2"],
        ["--weibull-k", "2", "--mean-speed", "5", "--weibull-scale", "6"],
        ["--rayleigh-mean", "-1"],
        ["--rayleigh-mean", "5", "--weibull-k", "2", "--mean-speed", "5"],
    ],
)
def test_bench_aep_bad_site_exits_2(tmp_path, capsys, site_args):
    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    code = main(["aep", "--optimize", str(folder), "--out", str(tmp_path / "aep"), *site_args])
    assert code == 2
    assert "error" in capsys.readouterr().err
    assert not (tmp_path / "aep").exists()


@pytest.mark.parametrize("site_args", [
    ["--weibull-k", "2", "--mean-speed", "1e6"],
    ["--weibull-k", "2", "--weibull-scale", "500"],
    ["--rayleigh-mean", "1e6"],
    ["--weibull-k", "2", "--mean-speed", "6", "--roughness-m", "1000"],
])
def test_implausible_site_exits_2(tmp_path, capsys, site_args):
    """A mean wind speed of 1e6 m/s or a roughness length of 1 km is refused, the option
    named."""
    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    code = main(["aep", "--optimize", str(folder), "--out", str(tmp_path / "aep"), *site_args])
    assert code == 2
    err = capsys.readouterr().err
    assert "implausible" in err or "not below" in err
    assert site_args[-2] in err


def test_one_wind_speed_is_refused(tmp_path, capsys):
    """A curve of one wind speed cannot be integrated: exit 2 naming the kind (before:
    AEP 0.000 MWh with exit 0)."""
    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance(), winds=(4.0,))
    code = main(["aep", "--optimize", str(folder), "--weibull-k", "2", "--mean-speed", "6",
                 "--out", str(tmp_path / "aep")])
    assert code == 2
    err = capsys.readouterr().err
    assert "cannot be integrated" in err and "summary.parquet" in err
    assert not (tmp_path / "aep").exists()


@pytest.mark.parametrize("stage", ["aep", "size"])
def test_scale_means_one_thing(tmp_path, capsys, stage):
    # issue 49: --scale was a campaign-length multiplier in bench synth and the Weibull
    # scale in m/s in aep and size; the Weibull one is --weibull-scale, and an option a
    # stage does not take is named by that stage ("bench aep: error: ...", not "bench:")
    from drivebench.cli import build_parser

    with pytest.raises(SystemExit) as exit_:
        main([stage, "--weibull-k", "2", "--scale", "6"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"bench {stage}: error: unrecognized arguments: --scale 6" in err
    args = build_parser([stage]).parse_args([stage, "--weibull-k", "2", "--weibull-scale", "6"])
    assert args.weibull_scale == 6.0
    synth = build_parser(["synth", "x"]).parse_args(["synth", "x", "--scale", "3"])
    assert synth.scale == 3  # bench synth's --scale: the campaign's length, alone


def test_aep_above_the_cut_in_names_what_it_leaves_out_on_the_console_and_in_aep_json(
        tmp_path, capsys):
    # issue 49: AP2 over 6:12:3 printed 8.966 MWh/yr noting only the hours above the grid;
    # the 43.8 % below 6 m/s counted as zero though the kite delivers there, and the
    # table's "cut-in 6.00" was the grid's edge
    import json

    from energy.site import energy_share, rayleigh

    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance(),
                                   winds=(6.0, 9.0, 12.0))
    assert main(["aep", "--optimize", str(folder), "--rayleigh-mean", "5.5",
                 "--out", str(tmp_path / "aep")]) == 0
    out = capsys.readouterr().out
    site = rayleigh(5.5)
    below, above = energy_share(site, 0.0, 6.0), energy_share(site, 12.0)
    row = next(line for line in out.splitlines() if line.startswith("elec-lim "))
    assert "below 6" in row and "6.00" not in row  # no cut-in the sweep did not find
    assert row.rstrip().endswith(f"{100 * below:.1f} % + {100 * above:.1f} %")
    assert f"({100 * below:.1f}% of the site's wind energy) count as zero power" in out
    assert f"({100 * above:.1f}% of the site's wind energy) have wind above" in out
    doc = json.loads((tmp_path / "aep" / "aep.json").read_text())
    kind = next(k for k in doc["kinds"] if k["kind"] == "elec-lim")
    assert kind["cut_in_elec_m_s"] is None and kind["delivers_at_grid_start"] is True
    assert kind["energy_below_grid"] == pytest.approx(below, rel=1e-9)
    assert kind["energy_above_grid"] == pytest.approx(above, rel=1e-9)
    assert kind["energy_left_out"] == pytest.approx(below + above, rel=1e-9)
