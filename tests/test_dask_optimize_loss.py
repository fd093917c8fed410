"""``bench optimize`` on a Dask cluster that loses its workers keeps what finished: the
scenarios solved are written with their figures, the others are failed as not run, the
run ends with its own exit code within the stated wait, and an earlier output that has
scenarios this run lost is kept (this run's written beside it as ``<out>.partial``).

The solver is the exact stand-in of test_sweep (``CycleBackend``): one scenario's solve
blocks until the test kills the cluster's only worker under it."""

from __future__ import annotations

import contextlib
import threading
import time
from dataclasses import dataclass

import pytest
from test_sweep import CycleBackend

from optimize.command import SweepRequest, partial_folder, run_optimize
from optimize.paper_model import PAPER_MODEL_PATH, paper_model
from optimize.resolve import resolve
from optimize.service import executors
from optimize.sweep_folder import read_manifest, read_summary
from optimize.sweep_options import WindGrid

distributed = pytest.importorskip("distributed")

#: set when the blocking solve has started; set again (RELEASE) when the test ends
STARTED, RELEASE = threading.Event(), threading.Event()


@dataclass(frozen=True)
class BlockingBackend(CycleBackend):
    """The stand-in whose warm solves at ``block_at`` m/s wait (until the test ends) after
    saying they started: their worker is killed while one runs."""

    block_at: tuple[float, ...] = (4.0, 7.0)

    def solve(self, ocp, scenario, warm):
        w = scenario.wind_speed_m_s
        if w in self.block_at:
            STARTED.set()
            RELEASE.wait(60)
        return super().solve(ocp, scenario, warm)


@pytest.fixture(autouse=True)
def short_wait(monkeypatch):
    monkeypatch.setattr(executors, "WORKER_WAIT_S", 1.0)
    monkeypatch.setattr(executors, "HEALTH_EVERY_S", 0.2)
    STARTED.clear()
    RELEASE.clear()
    yield
    RELEASE.set()


def _cluster():
    """An in-process cluster of one single-threaded worker (its IO loop must start within
    distributed's 10 s, which a loaded machine can miss: tried up to 3 times)."""
    for attempt in range(3):
        try:
            return distributed.LocalCluster(n_workers=1, threads_per_worker=1,
                                            processes=False, dashboard_address=None)
        except AssertionError:
            if attempt == 2:
                raise
    raise AssertionError("unreachable")


def _kill_workers_when_blocked(cluster):
    """On a daemon thread: once the blocking solve runs, close every worker at once (not
    waiting for its running task, as a killed process would not)."""
    def kill():
        if STARTED.wait(60):
            for worker in list(cluster.workers.values()):
                with contextlib.suppress(Exception):
                    cluster.sync(worker.close, executor_wait=False)

    threading.Thread(target=kill, daemon=True).start()


def _request(out, scheduler, claims=False):
    return SweepRequest(grid=WindGrid((4.0, 5.5, 7.0), ("elec-lim",)),
                        setup=resolve(drive_model=paper_model(), model_path=PAPER_MODEL_PATH),
                        model_note="paper model", scheduler=scheduler, out=out, claims=claims)


def _lost_run(out):
    with _cluster() as cluster:
        _kill_workers_when_blocked(cluster)
        t0 = time.monotonic()
        done = run_optimize(_request(out, cluster.scheduler_address), ["bench", "optimize"],
                            show_progress=False, backend=BlockingBackend())
        return done, time.monotonic() - t0


def test_a_lost_cluster_writes_what_finished_and_names_what_did_not(tmp_path):
    out = tmp_path / "optimize_out"
    done, wall_s = _lost_run(out)
    assert wall_s < 30  # the 1 s wait for a worker, not forever
    assert done.lost and "has had no worker" in done.lost and done.out == out
    assert done.kept is None
    rows = read_summary(out / "summary.parquet").set_index("scenario")
    # the seed (5.5, solved cold before its neighbours start from it) finished before the
    # loss: its figures are the stand-in's exact ones (period 4 s + w, CycleBackend)
    assert rows.loc["elec-lim-5.5", "success"]
    assert rows.loc["elec-lim-5.5", "period_s"] == pytest.approx(9.5, rel=1e-12)
    for name in ("elec-lim-4.0", "elec-lim-7.0"):
        assert not rows.loc[name, "success"]
        assert rows.loc[name, "status"].startswith("not run: cluster lost: --scheduler")
    manifest = read_manifest(out)
    assert manifest["cluster_lost"] == done.lost
    assert manifest["failed"] == ["elec-lim-4.0", "elec-lim-7.0"]


def test_a_lost_cluster_never_replaces_an_earlier_output_that_has_more(tmp_path):
    out = tmp_path / "optimize_out"
    # an earlier complete sweep of the same request, on a local pool
    complete = run_optimize(_request(out, None), ["bench", "optimize"], show_progress=False,
                            backend=CycleBackend())
    assert complete.summary["success"].all()
    before = (out / "summary.parquet").read_bytes()
    done, _ = _lost_run(out)
    assert done.lost and done.out == partial_folder(out)
    assert "2 converged scenarios this run has not (elec-lim-4.0, elec-lim-7.0)" in done.kept
    assert str(partial_folder(out)) in done.kept
    assert (out / "summary.parquet").read_bytes() == before  # untouched
    partial = read_summary(partial_folder(out) / "summary.parquet").set_index("scenario")
    assert partial.loc["elec-lim-5.5", "success"]
    assert partial.loc["elec-lim-7.0", "status"].startswith("not run")


def test_bench_optimize_says_the_cluster_was_lost_and_exits_4(tmp_path, monkeypatch, capsys):
    from drivebench.cli import main
    from optimize import command
    from optimize.cli import EXIT_CLUSTER_LOST

    real = command.run_optimize
    monkeypatch.setattr(command, "run_optimize", lambda request, line, show_progress:
                        real(request, line, show_progress, backend=BlockingBackend()))
    out = tmp_path / "optimize_out"
    with _cluster() as cluster:
        _kill_workers_when_blocked(cluster)
        code = main(["optimize", "--wind-grid", "4,5.5,7", "--scenarios", "elec-lim",
                     "--no-claims", "--no-progress", "--scheduler", cluster.scheduler_address,
                     "--out", str(out)])
    assert code == EXIT_CLUSTER_LOST == 4
    err = capsys.readouterr().err
    assert "CLUSTER LOST: --scheduler " in err and "has had no worker" in err
    assert "NOT RUN (cluster lost; a re-run solves them): elec-lim-4.0, elec-lim-7.0" in err
    assert read_summary(out / "summary.parquet")["success"].sum() == 1
