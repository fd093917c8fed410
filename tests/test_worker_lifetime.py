"""A killed ``bench`` takes the processes it started with it: before, each spawned worker of
the process pool held its own end of the task queue, never saw it close, and stayed (idle,
about 270 MB each) for as long as the machine ran; so did the progress queue's manager."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

DRIVER = '''
import os, sys, time
from optimize.service.executors import open_executor


def pid(_):
    time.sleep(0.5)  # both workers get a task
    return os.getpid()


if __name__ == "__main__":
    with open_executor(2) as handle:
        pids = {f.result() for f in [handle.executor.submit(pid, i) for i in range(2)]}
        with open(sys.argv[1] + ".tmp", "w") as f:
            f.write(" ".join(map(str, sorted(pids))))
        os.replace(sys.argv[1] + ".tmp", sys.argv[1])
        time.sleep(120)
'''


def children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (FileNotFoundError, ProcessLookupError):
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, dead but not yet reaped, does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")
def test_workers_end_when_the_process_that_started_them_is_killed(tmp_path):
    script, out = tmp_path / "driver.py", tmp_path / "pids"
    script.write_text(DRIVER, encoding="utf-8")
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, (
        str(root), os.environ.get("PYTHONPATH"))))}
    proc = subprocess.Popen([sys.executable, str(script), str(out)], env=env)
    try:
        deadline = time.monotonic() + 60
        while not out.exists():
            assert proc.poll() is None and time.monotonic() < deadline, "no workers started"
            time.sleep(0.1)
        workers = [int(p) for p in out.read_text().split()]
        assert len(workers) == 2 and all(alive(p) for p in workers)
        # the pool's workers, the progress queue's manager and the resource tracker
        started = children(proc.pid)
        assert set(workers) < set(started)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 10
        while any(alive(p) for p in started) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [p for p in started if alive(p)], "processes outlived their parent"
    finally:
        proc.kill()
