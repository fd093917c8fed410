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
    # optimize: the returned summary is the file's; the electrical objective wins on P_elec
    sweep = namespace["sweep"]
    pd.testing.assert_frame_equal(sweep.summary.reset_index(drop=True),
                                  pd.read_parquet(tmp_path / "optimize_out" / "summary.parquet"))
    assert sweep.summary["success"].all(), sweep.summary[["scenario", "status"]]
    by = sweep.summary.set_index("scenario")["avg_p_elec_w"]
    for w in ("6.0", "7.5"):
        assert by[f"elec-lim-{w}"] <= by[f"mech-lim-{w}"] + 1.0  # generated power is negative
    # aep: the file agrees with the returned table
    doc = json.loads((tmp_path / "aep_out" / "aep.json").read_text())
    table = namespace["energy"].table().set_index("kind")
    for row in doc["kinds"] if isinstance(doc["kinds"], list) else doc["kinds"].values():
        kind = row["kind"]
        assert row["aep_elec_mwh"] == pytest.approx(table.loc[kind, "aep_elec_mwh"], rel=1e-9)
    # size: the table is sizing.csv; the chosen drive is one of the candidates
    sizing = namespace["sizing"]
    csv = pd.read_csv(tmp_path / "size_out" / "sizing.csv")
    np.testing.assert_allclose(csv["aep_elec_mwh"], sizing.table["aep_elec_mwh"], rtol=1e-5)
    assert sizing.chosen in set(sizing.table["candidate"])
