"""What opening the sweep's process pool costs before any solve.

Opens :func:`optimize.service.executors.open_executor` with ``--workers`` workers,
runs one trivial task per worker, and closes it, ``--repeats`` times; prints per open
the wall time until the pool is usable, until the tasks are done, and the CPU time of
the child processes (the progress queue's manager and the workers). The tasks need no
drivebench module, so the children import only what their start-up needs.

Run::

    .venv/bin/python benchmarks/executor_start.py [--workers 2] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    from optimize.service.executors import open_executor  # not in the children's import

    print(f"load {os.getloadavg()[0]:.1f}")
    for _ in range(args.repeats):
        t0, c0 = time.perf_counter(), os.times()
        with open_executor(args.workers) as handle:
            t1 = time.perf_counter()
            list(handle.executor.map(abs, range(-args.workers, 0)))
            t2 = time.perf_counter()
        c1 = os.times()
        cpu = (c1.children_user + c1.children_system) - (c0.children_user + c0.children_system)
        print(f"open {t1 - t0:.2f} s, tasks done {t2 - t0:.2f} s, closed "
              f"{time.perf_counter() - t0:.2f} s; children's CPU {cpu:.2f} s")


if __name__ == "__main__":
    main()
