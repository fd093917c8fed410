"""The report's energy section from bench aep / bench size files."""

from __future__ import annotations

import json

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
    assert 'id="aep-table"' in html and 'id="sizing-chosen">x1<' in html
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
