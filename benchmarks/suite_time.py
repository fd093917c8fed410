"""Time the test suite: wall and CPU seconds of every test, and of the whole run.

Usage::

    .venv/bin/python benchmarks/suite_time.py [--repo PATH] [--top 25] [--out FILE] [PYTEST ARGS]

Runs ``python -m pytest -q -p no:cacheprovider`` in ``--repo`` (default: this
checkout; for a "before" column pass an older checkout, e.g. one made with ``git
archive COMMIT | tar -x -C DIR``: its tests import its own code) with this file
loaded as a pytest plugin. The plugin records, per test (setup + call + teardown),
the wall time and the CPU time (user + system) of the pytest process and of the
child processes it waited for (kill tests, solver workers, browsers), and writes
them as JSON. Prints the whole run's wall and CPU seconds, the load average
before and after, and the ``--top`` tests by CPU time. CPU seconds move far less
than wall seconds when other jobs share the machine; pytest-xdist is not used (CI
has 2 cores and the suite's CPU is what counts). Compare two JSON files with
``--compare BEFORE.json AFTER.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
RESULT_ENV = "SUITE_TIME_JSON"


def _cpu_s() -> float:
    """CPU seconds of this process and its waited-for children so far."""
    own, kids = (resource.getrusage(resource.RUSAGE_SELF),
                 resource.getrusage(resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


# -- the pytest plugin (active when this module is loaded with -p suite_time) ------------

_rows: dict[str, dict] = {}


def pytest_runtest_logstart(nodeid, location):  # noqa: ARG001 - pytest's hook signature
    _rows[nodeid] = {"start": (time.perf_counter(), _cpu_s())}


def pytest_runtest_logfinish(nodeid, location):  # noqa: ARG001
    row = _rows.get(nodeid)
    if row and "start" in row:
        wall0, cpu0 = row.pop("start")
        row["wall_s"], row["cpu_s"] = time.perf_counter() - wall0, _cpu_s() - cpu0


def pytest_sessionfinish(session, exitstatus):  # noqa: ARG001
    path = os.environ.get(RESULT_ENV)
    if path:
        Path(path).write_text(json.dumps({"tests": _rows, "exitstatus": int(exitstatus)}))


# -- the command -----------------------------------------------------------------------

def run_suite(repo: Path, out: Path, pytest_args: list[str]) -> dict:
    """Run the suite in ``repo`` with the plugin; returns the run's figures."""
    env = {**os.environ, RESULT_ENV: str(out),
           "PYTHONPATH": os.pathsep.join([str(HERE / "benchmarks"),
                                          os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                             "-p", "suite_time", *pytest_args], cwd=repo, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    result = json.loads(out.read_text())
    result.update({"repo": str(repo), "wall_s": time.perf_counter() - t0,
                   "cpu_s": usage.ru_utime + usage.ru_stime, "load_before": load0,
                   "load_after": os.getloadavg(), "exit": os.waitstatus_to_exitcode(status),
                   "summary": text.strip().splitlines()[-1] if text.strip() else ""})
    out.write_text(json.dumps(result, indent=1))
    return result


def show(result: dict, top: int) -> None:
    tests = result["tests"]
    print(f"{result['repo']}: {result['summary']}")
    print(f"wall {result['wall_s']:.1f} s, CPU {result['cpu_s']:.1f} s (pytest and its "
          f"children), load {result['load_before'][0]:.2f} before, "
          f"{result['load_after'][0]:.2f} after; {len(tests)} tests, "
          f"their CPU {sum(r['cpu_s'] for r in tests.values()):.1f} s")
    print(f"{'CPU [s]':>8s} {'wall [s]':>9s}  test")
    for node, r in sorted(tests.items(), key=lambda kv: -kv[1]["cpu_s"])[:top]:
        print(f"{r['cpu_s']:8.2f} {r['wall_s']:9.2f}  {node}")


def compare(before: dict, after: dict, top: int) -> None:
    b, a = before["tests"], after["tests"]
    print(f"{'before CPU':>10s} {'after CPU':>10s} {'before wall':>11s} {'after wall':>11s}  test")
    keys = sorted(set(b) | set(a), key=lambda k: -max(b.get(k, {}).get("cpu_s", 0),
                                                      a.get(k, {}).get("cpu_s", 0)))
    for k in keys[:top]:
        bb, aa = b.get(k, {}), a.get(k, {})

        def f(row, key):
            return f"{row[key]:.2f}" if key in row else "-"
        print(f"{f(bb, 'cpu_s'):>10s} {f(aa, 'cpu_s'):>10s} {f(bb, 'wall_s'):>11s} "
              f"{f(aa, 'wall_s'):>11s}  {k}")
    for name, r in (("before", before), ("after", after)):
        print(f"{name}: whole run wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, "
              f"load {r['load_before'][0]:.2f}/{r['load_after'][0]:.2f}; {r['summary']}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repo", type=Path, default=HERE, help="checkout whose suite runs")
    parser.add_argument("--top", type=int, default=25, help="slowest tests shown")
    parser.add_argument("--out", type=Path, default=HERE / "benchmarks" / "out" /
                        "suite_time.json", help="JSON written")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                        help="compare two JSON files instead of running")
    args, pytest_args = parser.parse_known_args()
    if args.compare:
        compare(*(json.loads(p.read_text()) for p in args.compare), args.top)
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    result = run_suite(args.repo.resolve(), args.out.resolve(), pytest_args)
    show(result, args.top)
    return 0 if result["exit"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
