"""bench fit writes its folder whole; readers refuse a mixed fit folder (issue: every
output all-or-nothing). benchmarks/output_kill.py runs the kill check at scale."""

from __future__ import annotations

import pytest
from fit_synthetic import paper_quadratic, synthetic_points, write_store
from kill_harness import run_output_kills

from bench.cli import main


def test_readers_refuse_a_mixed_fit_folder(tmp_path):
    """bench optimize and bench report on a fit folder with one file from another run:
    exit 2 naming the file."""
    store = tmp_path / "store"
    write_store(synthetic_points(paper_quadratic), store)
    fit = tmp_path / "fit_out"
    assert main(["fit", "--store", str(store), "--out", str(fit), "--order", "2"]) == 0
    other = tmp_path / "fit_other"
    assert main(["fit", "--store", str(store), "--out", str(other), "--order", "1"]) == 0
    (fit / "power_model.json").write_bytes((other / "power_model.json").read_bytes())
    assert main(["optimize", "--drive-model", str(fit / "power_model.json"),
                 "--wind-grid", "8", "--out", str(tmp_path / "opt")]) == 2
    assert main(["report", "--store", str(store), "--fit", str(fit), "--optimize",
                 str(tmp_path / "none"), "--out", str(tmp_path / "r.html")]) == 2
    assert not (tmp_path / "opt").exists()


def test_killed_fit_leaves_old_or_new(tmp_path):
    """bench fit (order 2) killed over an order-1 output: 1 SIGKILL at a random moment and
    3 deaths before file-system calls spread over the run (benchmarks/output_kill.py runs
    hundreds, in fresh processes); every time the folder is the old output or the whole
    new one, and the next run removes what a kill left. The runs are forked from a
    process that has imported bench fit, so each skips the imports."""
    store = tmp_path / "store"
    write_store(synthetic_points(paper_quadratic, n_motor=40, n_generator=40), store)
    args = ["fit", "--store", str(store), "--folds", "3"]
    figures = run_output_kills(tmp_path / "k", [*args, "--order", "1"],
                               [*args, "--order", "2"], n=1, steps=3, seed=3,
                               preload=["fitting.cli", "fitting.pipeline",
                                        "matplotlib.backends.backend_agg",
                                        "matplotlib.backends.backend_svg"])
    assert figures.tried == 4
    assert figures.mixed == 0 and figures.leftovers == 0, figures.problems
    assert figures.old > 0 and figures.new > 0


def test_fit_failing_late_leaves_the_old_output(tmp_path, monkeypatch, capsys):
    """A fit that fails in its last step (a figure) had already written four outputs;
    now the earlier output stays whole and unchanged."""
    from kill_harness import folder_files

    from fitting import figures

    store = tmp_path / "store"
    write_store(synthetic_points(paper_quadratic, n_motor=40, n_generator=40), store)
    out = tmp_path / "fit_out"
    args = ["fit", "--store", str(store), "--out", str(out), "--folds", "3"]
    assert main([*args, "--order", "1"]) == 0
    before = folder_files(out)

    def fail(*a, **kw):
        raise ValueError("Maximum allowed size exceeded")

    monkeypatch.setattr(figures, "residuals_figure", fail)
    with pytest.raises(ValueError):
        main([*args, "--order", "2"])
    assert folder_files(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fit_out", "store"]
