"""docs/python_api.md: the walk-through runs as written, and its results agree with the
stages' own files and with independent truths."""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import integrate, stats

from fitting.model_file import load_power_model

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "python_api.md"


def _walk_through() -> str:
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.DOTALL)
    assert len(blocks) == 1, "docs/python_api.md holds one walk-through"
    return blocks[0]


def test_walk_through_is_about_twenty_lines():
    code = [line for line in _walk_through().splitlines() if line.strip()]
    assert len(code) <= 22, len(code)


def test_walk_through_runs_as_written(tmp_path, monkeypatch):
    (tmp_path / "raw_measurements").symlink_to(ROOT / "raw_measurements")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()) as printed:
        exec(compile(_walk_through(), str(DOC), "exec"), namespace)  # noqa: S102
    assert "chosen drive:" in printed.getvalue()

    # ingest: the store's points are the campaign's (each quadrant measured)
    points = namespace["points"]
    assert min(points.counts().values()) > 100
    # fit: the campaign's known quadratic (raw_measurements/truth.json), a1..a3 within 3 %
    truth = json.loads((ROOT / "raw_measurements" / "truth.json").read_text())
    model = namespace["model"]
    assert model.terms == ((0, 0), (2, 0), (0, 2), (1, 1))
    ref = truth["reference_quadratic_rpm"]
    a = np.array([ref["a0_w"], ref["a1_w_per_rpm2"], ref["a2_w_per_nm2"],
                  ref["a3_w_per_rpm_nm"]])
    rel = np.abs(np.array(model.coefficients_rpm) / a - 1)
    assert rel[0] < 0.10 and np.all(rel[1:] < 0.03), rel
    # optimize: the returned summary is the file's; both cycles generate, the drive's
    # losses make the electrical power the smaller one
    sweep = namespace["sweep"]
    pd.testing.assert_frame_equal(sweep.summary.reset_index(drop=True),
                                  pd.read_parquet(tmp_path / "optimize_out" / "summary.parquet"))
    assert sweep.summary["success"].all(), sweep.summary[["scenario", "status"]]
    # the model object flew as given: written once, with the results, named by the manifest
    manifest = json.loads((tmp_path / "optimize_out" / "manifest.json").read_text())
    written = tmp_path / "optimize_out" / "power_model.json"
    assert manifest["drive_model"]["path"] == str(written.absolute())
    assert manifest["drive_model"]["model_sha256"] == model.sha256
    assert load_power_model(written).sha256 == model.sha256
    assert not (tmp_path / "optimize_out" / "given_power_model.json").exists()
    p_elec = sweep.summary["avg_p_elec_w"].to_numpy()
    assert (p_elec < 0).all() and (sweep.summary["avg_p_mech_w"].to_numpy() < p_elec).all()
    # aep: the file agrees with the returned table, and with the integral of the linear
    # curve between the two grid speeds over the Weibull density (no power outside them)
    doc = json.loads((tmp_path / "aep_out" / "aep.json").read_text())
    table = namespace["energy"].table().set_index("kind")
    rows = doc["kinds"] if isinstance(doc["kinds"], list) else list(doc["kinds"].values())
    assert [r["kind"] for r in rows] == ["elec-lim"]
    assert rows[0]["aep_elec_mwh"] == pytest.approx(table.loc["elec-lim", "aep_elec_mwh"],
                                                    rel=1e-9)
    site = namespace["site"]
    pdf = stats.weibull_min(site.k, scale=site.scale_m_s).pdf
    w = sweep.summary["wind_speed_m_s"].to_numpy()
    exact, _ = integrate.quad(lambda v: -np.interp(v, w, p_elec) * pdf(v), w[0], w[-1])
    assert rows[0]["aep_elec_mwh"] == pytest.approx(exact * 8760 / 1e6, rel=1e-6)
    # size: the table is sizing.csv; the chosen drive is one of the candidates
    sizing = namespace["sizing"]
    csv = pd.read_csv(tmp_path / "size_out" / "sizing.csv")
    np.testing.assert_allclose(csv["aep_elec_mwh"], sizing.table["aep_elec_mwh"], rtol=1e-5)
    assert sizing.chosen in set(sizing.table["candidate"])
    # every result prints short and names what it holds; in a notebook, as a table
    for name, holds in (("points", "points per quadrant"), ("model", "w^2"),
                        ("sweep", "converged"), ("energy", "AEP elec-lim"),
                        ("sizing", "chosen")):
        text = repr(namespace[name])
        assert len(text) < 1000 and holds in text, (name, text)
        assert "<table" in namespace[name]._repr_html_()
    assert repr(model.terms) == "(1, w^2, T^2, w*T)"
    # the plotting functions draw on given axes and return them; each figure to a file
    from matplotlib.figure import Figure

    import drivebench as db
    drawn = {
        "map": lambda ax: db.plot_efficiency_map("fit_out", ax, cycles=sweep.cycles(7.5)),
        "curves": lambda ax: namespace["energy"].plot_power_curves(ax),
        "cycle": lambda ax: sweep.plot_cycle("elec-lim-7.5", ax),
        "aep": lambda ax: namespace["energy"].plot_aep(ax),
    }
    for name, draw in drawn.items():
        fig = Figure()
        ax = fig.add_subplot()
        assert draw(ax) is ax and ax.has_data(), name
        fig.savefig(tmp_path / f"{name}.png")
        assert (tmp_path / f"{name}.png").stat().st_size > 5000


def test_the_walk_through_runs_from_standard_input():
    """Code read from standard input has no file for the worker processes to re-import
    (python - < walk_through.py): the pool still runs (here: one task of the solve
    service's executor)."""
    import subprocess
    import sys

    code = ("from optimize.service.executors import open_executor\n"
            "with open_executor(2) as h:\n"
            "    print(sorted(h.executor.map(abs, [-3, 4])))\n")
    done = subprocess.run([sys.executable, "-"], input=code, capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[3, 4]"
