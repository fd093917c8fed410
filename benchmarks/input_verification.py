"""What it costs every stage to verify its inputs against their recorded SHA-256.

On a store written by ``bench ingest`` (the 646 MiB benchmark campaign of
``ingest_benchmark.py``: ``bench synth DIR --scale 55``, then ``bench ingest DIR
--store STORE``), each timed ``--repeat`` times, best and median wall time:

* **points read, verified**: :func:`fitting.points.load_points` (what ``bench fit``
  reads: every listed points file, its size and SHA-256 checked, parsed);
* **points hash alone**: the SHA-256 of the same bytes (the verification's share);
* **whole store check**: :func:`bench.store.check_store` (what ``bench store check``
  and ``bench report`` do: every listed file of every kind, samples included).

Usage::

    .venv/bin/python benchmarks/input_verification.py STORE [--repeat 5]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import time
from pathlib import Path

from bench.store.damage import check_store
from bench.store.manifest import kind_files, read_manifest
from fitting.points import load_points


def _timed(fn, repeat: int) -> tuple[float, float]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), statistics.median(times)


def main() -> None:
    """Time the three reads and print one line each."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store", type=Path)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    manifest = read_manifest(args.store)
    points = list(kind_files(args.store, "points", manifest).values())
    every = [p for kind in ("points", "samples", "rejected")
             for p in kind_files(args.store, kind, manifest).values()]
    mib = {"points": sum(p.stat().st_size for p in points) / 2**20,
           "store": sum(p.stat().st_size for p in every) / 2**20}

    def hash_points() -> None:
        for p in points:
            hashlib.sha256(p.read_bytes()).hexdigest()

    rows = [("points read, verified (bench fit)", mib["points"],
             _timed(lambda: load_points(args.store), args.repeat)),
            ("points hash alone", mib["points"], _timed(hash_points, args.repeat)),
            ("whole store check (bench report, store check)", mib["store"],
             _timed(lambda: check_store(args.store, manifest), args.repeat))]
    print(f"store {args.store}: {len(points)} points files, {len(every)} files; "
          f"load average {os.getloadavg()[0]:.1f}")
    for name, size, (best, median) in rows:
        print(f"{name:<48} {size:8.1f} MiB  best {best:6.3f} s  median {median:6.3f} s  "
              f"{size / best:7.0f} MiB/s")


if __name__ == "__main__":
    main()
