"""The store survives a killed or a concurrent ingest (issue 13 section 1).

benchmarks/store_kill.py runs the same check with hundreds of kill moments.
"""

from __future__ import annotations

import subprocess
import time

from ingest_fixtures import make_timeseries_session
from kill_harness import REPO, ingest_command, run_kills, store_digest

from bench.ingest.pipeline import ingest
from bench.store.manifest import read_manifest
from bench.store.writer import StoreWriter


def test_sigkill_at_random_moments_leaves_old_or_new(tmp_path):
    """6 SIGKILLs at random moments of an ingest's work (parsing, processing, commit) and
    deaths just before file-system calls: 6 spread over all of them, and the ones just
    before and after each rename, replace or tree removal (every switch of the commit):
    the readers see exactly the old store or exactly the new one every time (content
    digest), and a re-ingest gives the new one with no staging or stale generation left.
    The ingests are forked from a process that has imported them, so no kill is wasted
    on the interpreter's start-up (benchmarks/store_kill.py kills fresh ``bench ingest``
    processes, start-up included, hundreds of times)."""
    figures = run_kills(tmp_path, 6, seed=13, steps=6, fork=True, around_switches=True)
    assert figures.tried - figures.fs_steps == 6 and figures.fs_steps >= 12
    assert figures.neither == 0, figures.problems
    assert figures.not_converged == 0 and figures.leftovers == 0, figures.problems
    # deaths landed before the switch, after it, and inside the commit
    assert figures.killed_old > 0 and figures.killed_new > 0
    assert figures.two_generations > 0


def test_two_concurrent_ingests_keep_both(tmp_path):
    """Two ingests into one store at once wait for the lock (and say so), then each
    merges into what the other wrote: no session is lost or orphaned, and the store
    equals the one the two ingests write one after the other."""
    a, b = tmp_path / "a", tmp_path / "b"
    make_timeseries_session(a, "motor_01", seed=1)
    make_timeseries_session(a, "motor_02", seed=4)
    make_timeseries_session(b, "gen_01", mode="generator", seed=2)
    make_timeseries_session(b, "gen_02", mode="generator", seed=6)
    store = tmp_path / "store"
    ingest([a], store, progress=False)  # a store exists, so a lock file to wait on
    logs = [tmp_path / f"err_{k}.txt" for k in range(2)]
    with StoreWriter(store):  # both ingests start while a third writer holds the lock
        procs = [subprocess.Popen([*ingest_command(c, store), "--workers", "1"], cwd=REPO,
                                  stdout=subprocess.DEVNULL, stderr=log.open("w"))
                 for c, log in zip((a, b), logs, strict=True)]
        deadline = time.monotonic() + 90
        while not all("waiting for another ingest" in log.read_text() for log in logs):
            assert time.monotonic() < deadline, [log.read_text() for log in logs]
            time.sleep(0.05)
    assert [p.wait(timeout=120) for p in procs] == [0, 0], [log.read_text() for log in logs]
    assert sorted(read_manifest(store)["sessions"]) == ["gen_01", "gen_02", "motor_01",
                                                        "motor_02"]
    # the same store, written one ingest after the other
    seq = tmp_path / "seq"
    ingest([a], seq, progress=False)
    ingest([b], seq, progress=False)
    assert store_digest(store) == store_digest(seq)
    assert sorted(p.name for p in store.iterdir()) == [".lock", read_manifest(store)[
        "generation"], "manifest.json"]


def test_second_ingest_with_no_wait_stops_clearly(tmp_path):
    a = tmp_path / "a"
    make_timeseries_session(a, "motor_01", seed=1)
    store = tmp_path / "store"
    ingest([a], store, progress=False)
    with StoreWriter(store):  # another writer holds the lock
        t0 = time.perf_counter()
        proc = subprocess.run([*ingest_command(a, store), "--no-wait"], cwd=REPO,
                              capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "another ingest" in proc.stderr and "is writing this store" in proc.stderr
    assert time.perf_counter() - t0 < 30
