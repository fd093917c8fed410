"""Kill ``bench ingest`` with SIGKILL at many random moments; count broken stores.

Usage::

    .venv/bin/python benchmarks/store_kill.py [--kills 200] [--seed 0] [--steps N]

Each kill hits an ingest of a changed campaign (one session changed, one added,
two kept) into a copy of the old store: first ``--kills`` SIGKILLs at a moment
uniform over the whole run (half of them) or over its last 40 % where the commit
is (the other half); then, since random timing rarely lands inside the few
milliseconds of the commit, an ingest that dies (``os._exit``) just before its
k-th file-system call, for every k (or ``--steps`` of them).
Prints the number of kill moments tried, how many left the store neither old
nor new (goal 0; compared by a digest of what the store's readers return), how
many re-ingests did not converge to the new store or left staging folders or
stale generations (goal 0 each), and where the kills landed. Exit code 1 when
any goal is missed. The harness is tests/kill_harness.py (also used by
tests/test_store_atomic.py with about 26 kills of ingests forked after their imports).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from kill_harness import run_kills  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=200, help="kill moments (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the kill moments")
    parser.add_argument("--steps", type=int, default=None,
                        help="file-system-call deaths (default: one before every call)")
    parser.add_argument("--verbose", action="store_true", help="one line per kill")
    args = parser.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="store_kill_") as work:
        figures = run_kills(Path(work), args.kills, seed=args.seed, steps=args.steps,
                            log=print if args.verbose else lambda msg: None)
    out = asdict(figures)
    problems = out.pop("problems")
    print(f"full ingest (subprocess, uninterrupted): {figures.full_run_s:.2f} s")
    for key, value in out.items():
        if key != "full_run_s":
            print(f"{key:18s} {value}")
    for p in problems:
        print("  " + p)
    print(f"wall time: {time.perf_counter() - t0:.0f} s")
    return 1 if figures.neither or figures.not_converged or figures.leftovers else 0


if __name__ == "__main__":
    sys.exit(main())
