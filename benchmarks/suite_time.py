"""Time the test suite's slowest tests one by one: wall and CPU seconds per test.

Usage::

    .venv/bin/python benchmarks/suite_time.py [--repo PATH] [--repeat 1] [NODE ...]

Each test node (default: the ``SLOW`` list below, the slowest tests of the suite)
runs in its own ``python -m pytest -q -p no:cacheprovider NODE`` child in ``--repo``
(default: this checkout; pass an older checkout, e.g. one made with ``git archive
COMMIT | tar -x -C DIR``, for the "before" column: its tests import its own code).
For each node it prints the time pytest gives its setup + call + teardown, the child's
wall time and the child's CPU time (user + system, from ``os.wait4``, which counts the
processes the test started and waited for: the kill tests' children, the solver's
workers), and the machine's load average before the run. CPU seconds move far less
than wall seconds when other jobs share the machine. Writes
``benchmarks/out/suite_time.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

#: the suite's slowest tests on 584e6e8 (pytest --durations=40, 229 s suite)
SLOW = [
    "tests/test_store_atomic.py::test_sigkill_at_random_moments_leaves_old_or_new",
    "tests/fitting/test_fit_atomic.py::test_killed_fit_leaves_old_or_new",
    "tests/test_fatrop.py::test_fatrop_confirms_the_stored_optimum_on_the_stage_layout",
    "tests/test_python_api.py::test_walk_through_runs_as_written",
    "tests/test_energy_sizing.py::test_interrupted_sweep_continues_where_it_stopped",
    "tests/fitting/test_fit_atomic.py::test_readers_refuse_a_mixed_fit_folder",
    "tests/test_energy_bands_resolve.py::test_sigma_equals_finite_difference_re_solve",
    "tests/test_initial_guess.py::test_start_from_the_guess_stays_at_its_optimum",
    "tests/test_ocp_rms_torque.py::test_rms_torque_bound_binds_and_costs_power",
]


def run_node(repo: Path, node: str) -> dict:
    """One pytest child for ``node``: its test time, wall and CPU seconds."""
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                             "--durations=0", "--durations-min=0", node], cwd=repo,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    test_s = sum(float(m) for m in re.findall(r"^([\d.]+)s (?:setup|call|teardown) ", out,
                                              re.MULTILINE))
    tail = out.strip().splitlines()[-1] if out.strip() else ""
    return {"node": node, "ok": proc.returncode == 0, "summary": tail, "test_s": test_s,
            "wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "load_1min": load}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("nodes", nargs="*", help="test node ids (default: the SLOW list)")
    parser.add_argument("--repo", type=Path, default=HERE, help="checkout whose tests run")
    parser.add_argument("--repeat", type=int, default=1, help="runs per node (best is kept)")
    args = parser.parse_args()
    rows = []
    print(f"{'test':75s} {'test [s]':>9s} {'wall [s]':>9s} {'CPU [s]':>8s} {'load':>5s}")
    for node in args.nodes or SLOW:
        runs = [run_node(args.repo, node) for _ in range(args.repeat)]
        best = min(runs, key=lambda r: r["cpu_s"])
        rows.append(best)
        flag = "" if best["ok"] else f"  FAILED: {best['summary']}"
        print(f"{node[-75:]:75s} {best['test_s']:9.1f} {best['wall_s']:9.1f} "
              f"{best['cpu_s']:8.1f} {best['load_1min']:5.2f}{flag}", flush=True)
    out = HERE / "benchmarks" / "out"
    out.mkdir(parents=True, exist_ok=True)
    (out / "suite_time.json").write_text(json.dumps({"repo": str(args.repo), "rows": rows},
                                                    indent=1))
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
