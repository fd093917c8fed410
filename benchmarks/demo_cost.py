"""What `make demo` costs, stage by stage: wall time, CPU time and the load around it.

Runs the stages of ``bench run PATH --out OUT`` (the same argument lists,
:func:`drivebench.run_cli.stage_commands`) one after the other, each as its own ``bench``
process, and prints per stage the wall time, the CPU time (user + system of the stage
and every worker process it waited for, from ``getrusage(RUSAGE_CHILDREN)``) and the
1-minute load average before and after; each stage's output goes to ``OUT_<stage>.log``
beside ``OUT``. On a shared machine the wall time carries the
other jobs' load; the CPU time does not (much): on 2 idle cores a stage needs at least
its CPU time / 2.

    .venv/bin/python benchmarks/demo_cost.py raw_measurements --out /tmp/demo_cost \
        [-- extra bench run options]
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="+")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args, extra = parser.parse_known_args(argv)
    from drivebench.cli import build_parser
    from drivebench.run_cli import stage_commands

    args.out.parent.mkdir(parents=True, exist_ok=True)
    run_argv = ["run", *args.paths, "--out", str(args.out), *[a for a in extra if a != "--"]]
    commands = stage_commands(build_parser(run_argv).parse_args(run_argv))
    bench = str(Path(sys.executable).with_name("bench"))
    rows = []
    for argv in commands:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        load0, t0 = os.getloadavg()[0], time.perf_counter()
        log = args.out.parent / f"{args.out.name}_{argv[0]}.log"
        with open(log, "w", encoding="utf-8") as fh:
            code = subprocess.run([bench, *argv], stdout=fh, stderr=subprocess.STDOUT).returncode
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        rows.append({"stage": argv[0], "exit": code, "wall_s": wall, "cpu_s": cpu,
                     "load1_before": load0, "load1_after": os.getloadavg()[0]})
        r = rows[-1]
        print(f"{r['stage']:<9} exit {code}  wall {wall:7.1f} s  cpu {cpu:7.1f} s  "
              f"load {r['load1_before']:.1f} -> {r['load1_after']:.1f}", flush=True)
        if code:
            break
    wall, cpu = sum(r["wall_s"] for r in rows), sum(r["cpu_s"] for r in rows)
    print(f"{'total':<9}         wall {wall:7.1f} s  cpu {cpu:7.1f} s  "
          f"(cpu / 2 = {cpu / 2:.1f} s: the floor on 2 idle cores)")
    print(f"wind grid: {commands[2][commands[2].index('--wind-grid') + 1]}")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0 if all(r["exit"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
