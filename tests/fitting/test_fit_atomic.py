"""bench fit writes its folder whole; readers refuse a mixed fit folder (issue: every
output all-or-nothing). benchmarks/output_kill.py runs the kill check at scale."""

from __future__ import annotations

import shutil

import pytest
from fit_synthetic import paper_quadratic, synthetic_points, write_store
from kill_harness import run_output_kills

from drivebench.cli import main


def test_readers_refuse_a_mixed_fit_folder(tmp_path, paper_fits):
    """bench optimize and bench report on a fit folder with one file from another run:
    exit 2 naming the file."""
    store, (order_2, _), (order_1, _) = paper_fits["store"], paper_fits[2], paper_fits[1]
    fit = tmp_path / "fit_out"
    shutil.copytree(order_2, fit)
    (fit / "power_model.json").write_bytes((order_1 / "power_model.json").read_bytes())
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


def test_fit_failing_late_leaves_the_old_output(tmp_path, monkeypatch, paper_fits):
    """A fit that fails in its last step (a figure) had already written four outputs;
    now the earlier output stays whole and unchanged."""
    from kill_harness import folder_files

    from fitting import figures

    out = tmp_path / "fit_out"
    shutil.copytree(paper_fits[1][0], out)  # an order-1 output of the store
    args = ["fit", "--store", str(paper_fits["store"]), "--out", str(out)]
    before = folder_files(out)

    def fail(*a, **kw):
        raise ValueError("Maximum allowed size exceeded")

    monkeypatch.setattr(figures, "residuals_figure", fail)
    with pytest.raises(ValueError):
        main([*args, "--order", "2"])
    assert folder_files(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) in (["fit_out"], [".fit_out.lock", "fit_out"])
