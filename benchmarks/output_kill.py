"""Kill ``bench fit`` or ``bench optimize`` writing over an earlier output; count mixed folders.

Usage::

    .venv/bin/python benchmarks/output_kill.py --stage fit [--kills 20] [--steps N]
    .venv/bin/python benchmarks/output_kill.py --stage optimize [--kills 6] [--steps 8]

The earlier output is written first (fit: ``--order 1``; optimize: one wind speed of
7 m/s), then each kill hits the new run (fit: ``--order 2``; optimize: 8 m/s) writing
into a copy of it: ``--kills`` SIGKILLs at a moment uniform over the run, then
deaths (``os._exit``) just before the k-th file-system call for ``--steps`` values
of k spread over all calls (default: every call). Prints the kill moments tried,
how many left the folder the old output, one whole new output (``run.json`` checks,
new run id) or mixed (goal 0), and whether the next run removed what kills left.
Exit code 1 when a folder was left mixed. The harness is tests/kill_harness.py
(tests/fitting/test_fit_atomic.py runs 4 kills of bench fit).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fitting"))

from fit_synthetic import paper_quadratic, synthetic_points, write_store  # noqa: E402
from kill_harness import run_output_kills  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=["fit", "optimize"], default="fit")
    parser.add_argument("--kills", type=int, default=20, help="random SIGKILL moments")
    parser.add_argument("--steps", type=int, default=None,
                        help="file-system-call deaths (default: one before every call)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--verbose", action="store_true", help="one line per kill")
    args = parser.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="output_kill_") as tmp:
        work = Path(tmp)
        if args.stage == "fit":
            store = work / "store"
            write_store(synthetic_points(paper_quadratic), store)
            common = ["fit", "--store", str(store)]
            old, new = [*common, "--order", "1"], [*common, "--order", "2"]
        else:
            common = ["optimize", "--scenarios", "elec-lim", "--intervals", "20",
                      "--workers", "1", "--no-claims"]
            old, new = [*common, "--wind-grid", "7"], [*common, "--wind-grid", "8"]
        figures = run_output_kills(work / "kills", old, new, n=args.kills, steps=args.steps,
                                   seed=args.seed,
                                   log=print if args.verbose else lambda msg: None)
    out = asdict(figures)
    problems = out.pop("problems")
    print(f"bench {args.stage}: full run (subprocess, uninterrupted) {figures.full_run_s:.1f} s")
    for key, value in out.items():
        if key != "full_run_s":
            print(f"{key:20s} {value}")
    for p in problems:
        print("  " + p)
    print(f"wall time: {time.perf_counter() - t0:.0f} s")
    return 1 if figures.mixed or figures.leftovers else 0


if __name__ == "__main__":
    sys.exit(main())
