"""``bench aep`` end to end on a synthetic optimize folder, and the band against Monte Carlo."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from bench.cli import main
from energy.aep import aep_mwh
from energy.assess import assess
from energy.curve import read_optimize_run
from energy.site import Weibull
from fitting.model_file import paper_model, save_power_model

WINDS = (4.0, 5.5, 7.0, 8.5, 10.0)
KINDS = {"elec-lim": ("electrical", True), "mech-free": ("mechanical", False)}


def _model_with_covariance():
    m = paper_model()
    # a covariance with correlations: 1 % of each coefficient, correlation 0.3
    s = 0.01 * np.abs(np.array(m.coefficients_rpm))
    cov = 0.3 * np.outer(s, s) + 0.7 * np.diag(s**2)
    return dataclasses.replace(m, covariance_rpm=tuple(map(tuple, cov)))


def write_optimize_folder(folder, model, failed=()):
    """A folder laid out as docs/schemas.md §5 with cycles made up per wind speed."""
    rng = np.random.default_rng(1)
    rows, traj = [], []
    for kind, (objective, limits) in KINDS.items():
        for v in WINDS:
            name = f"{kind}-{v:.1f}"
            n = 40
            t = np.linspace(0, 1, n, endpoint=False)
            speed = -200.0 * v * np.sin(2 * np.pi * t) - 60 * v + rng.normal(0, 5, n)
            torque = np.abs(8.0 * v * (1 + 0.5 * np.cos(2 * np.pi * t)))
            w = np.full(n, 1.0 / n)
            p_elec = float(np.sum(w * model.p_elec_w(speed, torque)))
            p_mech = float(np.sum(w * speed / 9.549296585513721 * torque))
            ok = name not in failed
            rows.append({"scenario": name, "kind": kind, "objective": objective,
                         "drive_limits": limits, "wind_speed_m_s": v, "success": ok,
                         "status": "Solve_Succeeded" if ok else "Infeasible_Problem_Detected",
                         "avg_p_elec_w": p_elec if ok else np.nan,
                         "avg_p_mech_w": p_mech if ok else np.nan,
                         "period_s": 5.0 if ok else np.nan,
                         "peak_speed_rpm": float(np.max(np.abs(speed))),
                         "peak_torque_nm": float(np.max(torque))})
            if ok:
                traj.append(pd.DataFrame({"scenario": name, "kind": kind, "wind_speed_m_s": v,
                                          "weight": w, "speed_rpm": speed, "torque_nm": torque}))
    folder.mkdir(parents=True)
    pd.DataFrame(rows).to_parquet(folder / "summary.parquet")
    pd.concat(traj).to_parquet(folder / "trajectories.parquet")
    model_path = folder / "power_model.json"
    save_power_model(model, model_path)
    (folder / "manifest.json").write_text(json.dumps({
        "schema": "drivebench.optimize", "schema_version": 1,
        "wind_speeds_m_s": list(WINDS), "kinds": list(KINDS),
        "drive_model": {"path": str(model_path), "model_sha256": model.sha256, "name": model.name},
        "cut_in": [],
    }))
    return folder


def test_band_equals_monte_carlo_over_the_coefficients(tmp_path):
    # For fixed cycles P_i = g_i . a exactly, so the AEP's spread under a ~ N(c, Sigma)
    # is the propagated sigma; 20000 draws estimate a std to about 0.5 % (tolerance 3 %).
    model = _model_with_covariance()
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
    aeps = [aep_mwh(curve.wind_m_s, p, site) for p in draws @ basis.T]
    assert a.kinds["elec-lim"].sigma_elec_model_mwh == pytest.approx(np.std(aeps), rel=0.03)
    assert a.kinds["elec-lim"].elec.aep_mwh == pytest.approx(np.mean(aeps), rel=0.01)


def test_bench_aep_writes_every_file(tmp_path, capsys):
    folder = write_optimize_folder(tmp_path / "opt", _model_with_covariance(),
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
    curves = pd.read_csv(out / "power_curves.csv", comment="#")
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
        ["--weibull-k", "2", "--mean-speed", "5", "--scale", "6"],
        ["--rayleigh-mean", "-1"],
        ["--rayleigh-mean", "5", "--weibull-k", "2", "--mean-speed", "5"],
    ],
)
def test_bench_aep_bad_site_exits_2(tmp_path, capsys, site_args):
    folder = write_optimize_folder(tmp_path / "opt", _model_with_covariance())
    code = main(["aep", "--optimize", str(folder), "--out", str(tmp_path / "aep"), *site_args])
    assert code == 2
    assert "error" in capsys.readouterr().err
    assert not (tmp_path / "aep").exists()
