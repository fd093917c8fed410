"""Scaling of the bench optimize sweep with the worker count, and its critical path.

Runs the paper sweep (4 kinds x 4:10:1.5, the start graph of
:func:`optimize.service.plan.plan_graph`) on 1, 2, ... worker processes and reports,
per run: the sweep's wall time, the total solver time (the sum of every scenario's
solver runs), and the critical path: the longest sum of solver wall times along the
start dependencies (each scenario's ``warm_source`` back to its seed), which no
number of cores can beat. On N cores the sweep cannot take less than
``max(critical path, total / N)`` plus each worker's setup (NLP build) and the
task overhead. The machine load is recorded beside each run: the machine may be
shared, and load inflates every timing.

Run::

    .venv/bin/python benchmarks/sweep_scaling.py --workers 1,2

Writes ``benchmarks/out/sweep_scaling.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
from pathlib import Path

from kernel.files import write_text_atomic
from optimize.kinds import DEFAULT_KINDS
from optimize.problem.options import OcpOptions
from optimize.service import Problem, SweepTasks, run_sweep
from optimize.service.executors import open_executor
from optimize.service.plan import plan_graph
from optimize.sweep_options import DEFAULT_WIND_GRID, parse_kinds, parse_wind_grid
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

OUT = Path(__file__).resolve().parent / "out"


def critical_path_s(outcomes) -> float:
    """The longest sum of solver wall times [s] along the start dependencies: each
    scenario's own runs plus those of its ``warm_source``, back to a cold start."""
    by_name = {o.name: o for o in outcomes}
    memo: dict[str, float] = {}

    def path(name: str, seen: frozenset) -> float:
        if name not in memo:
            o = by_name[name]
            src = o.warm_source
            inner = path(src, seen | {name}) if src in by_name and src not in seen else 0.0
            memo[name] = o.total_wall_time_s + inner
        return memo[name]

    return max(path(n, frozenset()) for n in by_name)


def run(problem: Problem, winds, kinds, workers: int) -> dict:
    """One sweep on ``workers`` processes: wall, total and critical-path times."""
    load_before = list(os.getloadavg())
    with open_executor(workers) as handle:
        result = run_sweep(SweepTasks(problem, plan_graph(winds, kinds), selected=kinds), handle)
    outcomes = result.outcomes
    warm = [o.attempts[-1].iterations for o in outcomes if o.depth > 0]
    record = result.record()
    return {
        "workers": workers,
        "wall_s": result.wall_time_s,
        "total_solver_s": sum(o.total_wall_time_s for o in outcomes),
        "critical_path_s": critical_path_s(outcomes),
        "converged": sum(o.success for o in outcomes),
        "scenarios": len(outcomes),
        "max_depth": max(o.depth for o in outcomes),
        "warm_iterations_median": statistics.median(warm) if warm else None,
        "worker_setup_s": [w["build_time_s"] for w in record["workers"]],
        "load_before": load_before,
        "load_after": list(os.getloadavg()),
    }


def main() -> None:
    """Run the sweep at each worker count; print one line each and write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", default=f"1,{len(os.sched_getaffinity(0))}",
                    help="comma list of worker counts (default: 1 and the usable cores)")
    ap.add_argument("--wind-grid", default=DEFAULT_WIND_GRID)
    ap.add_argument("--scenarios", default=DEFAULT_KINDS)
    args = ap.parse_args()
    winds, kinds = parse_wind_grid(args.wind_grid), parse_kinds(args.scenarios)
    system = load_system()
    drive, _ = drive_in_force(system)
    problem = Problem.for_system(system.in_force(drive), drive.power_model, OcpOptions())
    runs = []
    for n in (int(x) for x in args.workers.split(",")):
        runs.append(run(problem, winds, kinds, n))
        r = runs[-1]
        print(f"{n} workers: wall {r['wall_s']:.1f} s, solver total {r['total_solver_s']:.1f} s, "
              f"critical path {r['critical_path_s']:.1f} s, {r['converged']}/{r['scenarios']} "
              f"converged, depth <= {r['max_depth']}, median warm iterations "
              f"{r['warm_iterations_median']}, load {r['load_before'][0]:.1f} -> "
              f"{r['load_after'][0]:.1f}")
    OUT.mkdir(exist_ok=True)
    write_text_atomic(OUT / "sweep_scaling.json", json.dumps({"runs": runs}, indent=2))


if __name__ == "__main__":
    main()
