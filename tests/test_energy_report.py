"""The report's energy section from bench aep / bench size files."""

from __future__ import annotations

import json

import pytest
from energy_fixtures import model_with_covariance, write_optimize_folder

from drivebench.cli import main
from reports.render import build_context, render


def test_energy_section_renders_aep_table_bands_and_sizing(tmp_path):
    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    assert main(["aep", "--optimize", str(folder), "--rayleigh-mean", "5.5",
                 "--out", str(tmp_path / "aep")]) == 0
    size = tmp_path / "size"
    size.mkdir()
    cands = [{"candidate": f"x{s:g}", "rated_torque_nm": 78.0 * s, "peak_torque_nm": 390.0 * s,
              "nominal_power_w": 8200.0 * s, "aep_elec_mwh": a, "aep_share_of_best": a / 2.0,
              "capacity_factor_elec": 0.03, "rms_bound_active_at": "7", "n_converged": 3,
              "n_winds": 3} for s, a in ((0.5, 1.5), (1.0, 1.97), (2.0, 2.0))]
    (size / "sizing.json").write_text(json.dumps({
        "schema": "drivebench.sizing", "candidates": cands, "best": "x2", "chosen": "x1",
        "tolerance": 0.02, "law": "P_s(n, T) = s P_1(n, T/s)", "wind_speeds_m_s": [5.5, 7, 8.5],
        "wall_time_s": 12.0, "executor": "process pool, 2 workers", "n_solved": 9,
        "n_loaded": 0}))
    none = tmp_path / "none"
    ctx = build_context(none, none, none, ["bench", "report"], tmp_path / "aep", size)
    e = ctx["energy"]
    assert e["missing"] == []
    assert [r["kind"].split()[0] for r in e["table"]] == ["elec-lim", "mech-free"]
    assert e["table"][0]["band"] != "n/a"
    assert e["figure"] is not None and e["sizing"]["figure"] is not None
    html = render(ctx)
    assert 'id="aep-table"' in html and 'id="sizing-chosen">No decision recorded' in html
    assert any(k == "drive sizing" for k, _ in ctx["headline"])


def test_energy_section_says_what_is_missing_or_not_run(tmp_path):
    ctx = build_context(tmp_path, tmp_path, tmp_path, ["bench", "report"], tmp_path / "aep",
                        tmp_path / "size")
    assert ctx["energy"]["missing"] == []  # optional stages that were not run ...
    assert "Not run: bench aep" in render(ctx)  # ... are said so
    (tmp_path / "aep").mkdir()
    ctx = build_context(tmp_path, tmp_path, tmp_path, ["bench", "report"], tmp_path / "aep",
                        tmp_path / "size")
    assert str(tmp_path / "aep" / "aep.json") in ctx["energy"]["missing"]
    assert "not available" in render(ctx)


def _docs(size_winds, aep_winds, power, site):
    """An aep.json, its elec-lim curve and a sizing.json whose x1 flies the same curve
    (``power(v)`` [W]) on its own grid, each AEP integrated on its grid."""
    import numpy as np
    import pandas as pd

    from energy.aep import aep_mwh

    curve = pd.DataFrame({"kind": "elec-lim", "wind_speed_m_s": aep_winds,
                          "p_elec_w": [power(v) for v in aep_winds]})
    aep_doc = {"site": {**site.to_dict(), "note": "aep"},
               "optimize": {"drive_model": {"model_sha256": "m"}},
               "kinds": [{"kind": "elec-lim", "aep_elec_mwh": aep_mwh(
                   np.array(aep_winds), curve["p_elec_w"].to_numpy(), site)}]}
    sizing = {"site": {**site.to_dict(), "note": "size"},
              "reference_drive": {"model_sha256": "m"},
              "candidates": [{"candidate": "x1", "scale": 1.0, "aep_elec_mwh": aep_mwh(
                  np.array(size_winds), np.array([power(v) for v in size_winds]), site)}],
              "solves": [{"candidate": "x1", "wind_speed_m_s": v} for v in size_winds]}
    return aep_doc, curve, sizing


def test_sizing_says_how_much_of_x1s_aep_difference_the_wind_grids_make():
    # issue 42: x1 and the AEP table's elec-lim differ by their grids only when x1 is the
    # same drive; on a curve linear between the AEP grid's speeds the split is exact
    import re

    from energy.site import Weibull
    from reports.energy_section import grid_difference

    site = Weibull.from_mean(2.0, 5.5)
    aep_winds = [4.0, 5.5, 7.0, 8.5, 10.0, 11.5]
    aep_doc, curve, sizing = _docs([5.5, 8.5, 11.5], aep_winds, lambda v: -60.0 * v**3, site)
    text = grid_difference(aep_doc, curve, sizing)
    own = sizing["candidates"][0]["aep_elec_mwh"]
    other = aep_doc["kinds"][0]["aep_elec_mwh"]
    assert f"{own:.3f} against {other:.3f}" in text
    grids = float(re.search(r"the grids make ([-+.\d]+) MWh/yr", text).group(1))
    assert grids == pytest.approx(own - other, abs=1e-3)  # all of it: the same curve
    assert "+0.000 MWh/yr (+0.00 %)" in text  # nothing left for the solves
    # the same grid: no split; another site or other losses: not compared
    aep_doc, curve, sizing = _docs(aep_winds, aep_winds, lambda v: -60.0 * v**3, site)
    assert grid_difference(aep_doc, curve, sizing).endswith("(+0.00 %), on the same wind grid.")
    sizing["reference_drive"]["model_sha256"] = "other"
    assert "not compared" in grid_difference(aep_doc, curve, sizing)


def test_sizing_table_states_the_limits_each_candidate_flew():
    from energy.sizing import limits_text

    assert limits_text({"peak_torque_nm": 78.0, "rated_torque_nm": 78.0,
                        "max_speed_rpm": 1500.0}) == (
        "torque <= 78.0 N m, RMS implied, |speed| <= 1500 rpm")
    assert limits_text({"peak_torque_nm": 390.0, "rated_torque_nm": 78.0,
                        "max_speed_rpm": 1500.0}) == (
        "torque <= 390.0 N m, RMS <= 78.0 N m, |speed| <= 1500 rpm")


def test_key_results_sign_the_chosen_drive(tmp_path):
    # issue 49: Key results said "smallest within 2.0 % of the best AEP: x1.5" and a run-on
    # about coverage; its rating, power and AEP were only in section 5's table
    from energy.decision import decision, grid_coverage
    from energy.site import Weibull
    from reports.energy_section import decision_rows

    site = Weibull.from_mean(2.0, 5.5)
    winds = (4.0, 7.0, 10.0, 13.0, 16.0, 19.0)
    cands = [{"candidate": f"x{s:g}", "scale": s, "rated_torque_nm": 78.0 * s,
              "peak_torque_nm": 78.0 * s, "max_speed_rpm": 1500.0,
              "nominal_power_w": 8200.0 * s, "aep_elec_mwh": a, "aep_share_of_best": a / 4.382}
             for s, a in ((1.0, 3.834), (1.5, 4.264), (2.0, 4.382))]
    recs = [{"candidate": c["candidate"], "wind_speed_m_s": w, "success": True,
             "avg_p_elec_w": 100.0 if w == 4.0 else -1000.0} for c in cands for w in winds]
    import pandas as pd

    cov = grid_coverage(site, winds, recs)
    sizing = {"candidates": cands, "tolerance": 0.02, "coverage": cov,
              "decision": decision(pd.DataFrame(cands), recs, site, cov, 0.02),
              "site": site.to_dict(), "reference_drive": {"model_sha256": "abc"}}
    aep = {"site": site.to_dict(), "optimize": {"drive_model": {"model_sha256": "abc"}},
           "kinds": [{"kind": "elec-lim", "aep_elec_mwh": 3.6, "ci95_aep_elec_low_mwh": 3.55,
                      "ci95_aep_elec_high_mwh": 3.65}]}
    (key, chosen), (_, grid) = decision_rows(sizing, aep)
    assert key == "drive chosen"
    assert chosen.startswith("x2: torque <= 156.0 N m, RMS implied, |speed| <= 1500 rpm, "
                             "nominal power 16400 W; electrical AEP 4.382 MWh/yr")
    assert "95 %: +-1.4 %, x1's relative band" in chosen  # 0.05 / 3.6
    assert "it is the best" in chosen
    assert "the next smaller, x1.5, delivers 4.264 MWh/yr, 97.3 % of the best (the rule needs " \
           "98 %)" in chosen
    assert grid.startswith("the sizing grid 4-19 m/s covers 99.8 % of the site's wind energy")
    # on another site, no band is carried
    (_, chosen), _ = decision_rows(sizing, {**aep, "site": Weibull(2.0, 9.0).to_dict()})
    assert "no band" in chosen

