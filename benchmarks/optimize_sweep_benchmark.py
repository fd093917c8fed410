"""Benchmark of the bench optimize sweep.

Measures, on this machine:

* the cold start (homotopy) at the middle wind speed, in this process;
* the whole sweep (default 20 scenarios: 4 kinds x 4:10:1.5) with 1 and with 2
  worker processes, each chain's start included (from the shipped initial guess,
  or the homotopy with ``--no-stored-guess``), cut-in searches and trust checks
  excluded;
* per warm solve: wall time and iterations (median and max), and the number
  converged;
* after the first sweep, the trust checks (mesh check at 2x intervals of each
  kind's middle-wind cycle, CVODES simulation of every cycle), untimed.

Goals on a 2-core machine: cold start <= 45 s, median warm solve <= 3 s,
whole sweep <= 120 s on 2 workers, 20/20 converged. The machine load (other
processes share the CPU) is recorded before and after, since it inflates
every timing.

Run::

    .venv/bin/python benchmarks/optimize_sweep_benchmark.py            # full
    .venv/bin/python benchmarks/optimize_sweep_benchmark.py --workers 2 --repeats 1

Writes ``benchmarks/out/optimize_sweep.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from fitting.model_file import load_power_model
from kernel.files import write_text_atomic
from optimize.kinds import DEFAULT_KINDS
from optimize.paper_model import PAPER_MODEL_PATH
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.resolve import resolve
from optimize.service import OcpBackend, Problem, SweepTasks, run_sweep
from optimize.service.executors import open_executor
from optimize.service.plan import middle_index, plan_graph
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.sweep.trust import run_trust_checks
from optimize.sweep_options import DEFAULT_WIND_GRID, parse_kinds, parse_wind_grid

OUT = Path(__file__).resolve().parent / "out"
GOALS = {"cold_start_s": 45.0, "median_warm_solve_s": 3.0, "sweep_2_workers_s": 120.0}


def machine_state() -> dict:
    """CPU count and load averages (1, 5, 15 min)."""
    return {"nproc": os.cpu_count(), "loadavg": list(os.getloadavg())}


def bench_cold_start(problem: Problem, wind: float, repeats: int) -> list[dict]:
    """Cold start (the homotopy, no stored guess) of elec-lim at ``wind`` [m/s], ``repeats``
    times, in this process."""
    backend = OcpBackend()
    t0 = time.perf_counter()
    ocp = backend.build(problem)
    build_s = time.perf_counter() - t0
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = solve_by_homotopy(ocp, Scenario.of_kind("elec-lim", wind))
        runs.append(
            {
                "build_s": build_s,
                "wall_s": time.perf_counter() - t0,
                "solver_wall_s": res.wall_time_s,
                "iterations": res.iterations,
                "status": res.status,
                "stages": list(res.stages),
            }
        )
        print(f"cold start: {res.status}, {res.iterations} it, {runs[-1]['wall_s']:.1f} s")
    return runs


def bench_sweep(problem: Problem, winds, kinds, workers: int, trust: bool) -> dict:
    """The whole sweep on ``workers`` processes; per-solve statistics; optional trust checks
    (after the timed sweep, on the same workers)."""
    with open_executor(workers) as handle:
        steps = plan_graph(winds, kinds)
        result = run_sweep(SweepTasks(problem, steps, selected=kinds), handle)
        checks = run_trust_checks(problem, result.outcomes, winds, handle) if trust else None
    warm = [a for o in result.outcomes for a in o.attempts if a.source is not None]
    starts = [(o, a) for o in result.outcomes for a in o.attempts if a.source is None]
    ok_warm = [a for a in warm if a.success]
    times = [a.wall_time_s for a in ok_warm] or [float("nan")]
    iters = [a.iterations for a in ok_warm] or [0]
    out = {
        "workers": workers,
        "start_graph": [(s.name, s.warm_from and s.warm_from.name, s.depth) for s in steps],
        "wall_s": result.wall_time_s,
        "converged": sum(o.success for o in result.outcomes),
        "scenarios": len(result.outcomes),
        "failed": [(o.name, o.status) for o in result.outcomes if not o.success],
        "retried": [o.name for o in result.outcomes if len(o.attempts) > 1],
        "warm_solves": len(warm),
        "warm_failed": len(warm) - len(ok_warm),
        "warm_wall_s": {"median": statistics.median(times), "max": max(times)},
        "warm_iterations": {"median": statistics.median(iters), "max": max(iters)},
        "chain_starts": [
            {"scenario": o.name, "start": getattr(o.result, "start", None),
             "wall_s": a.wall_time_s, "iterations": a.iterations, "status": a.status}
            for o, a in starts
        ],
        "build_s": [c.build_time_s for c in result.chains],
        "per_scenario": [
            {
                "name": o.name,
                "status": o.status,
                "source": o.warm_source,
                "wall_s": o.total_wall_time_s,
                "iterations": o.attempts[-1].iterations,
                "avg_p_elec_w": getattr(o.result, "avg_p_elec_w", None) if o.success else None,
                "avg_p_mech_w": getattr(o.result, "avg_p_mech_w", None) if o.success else None,
                "period_s": getattr(o.result, "period_s", None) if o.success else None,
            }
            for o in result.outcomes
        ],
    }
    if checks is not None:
        out["trust"] = checks
        print("\n".join(checks["lines"]))
    print(
        f"sweep on {workers} worker(s): {out['converged']}/{out['scenarios']} converged in "
        f"{out['wall_s']:.1f} s; warm solve median {out['warm_wall_s']['median']:.2f} s, "
        f"max {out['warm_wall_s']['max']:.2f} s; iterations median "
        f"{out['warm_iterations']['median']}, max {out['warm_iterations']['max']}"
    )
    return out


def main() -> None:
    """Parse options, run the measurements, write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wind-grid", default=DEFAULT_WIND_GRID)
    ap.add_argument("--scenarios", default=DEFAULT_KINDS)
    ap.add_argument("--intervals", type=int, default=40)
    ap.add_argument("--tol", type=float, default=SolverOptions.tol, help="IPOPT tolerance")
    ap.add_argument("--warm-bound-push", type=float, default=SolverOptions.warm_bound_push,
                    help="IPOPT warm_start_*bound_push/frac of warm solves")
    ap.add_argument("--no-stored-guess", action="store_true",
                    help="start every chain by the homotopy (as before the shipped guess)")
    ap.add_argument("--workers", default="1,2", help="comma list of worker counts to run")
    ap.add_argument("--repeats", type=int, default=1, help="cold-start repetitions")
    ap.add_argument(
        "--no-trust", action="store_true", help="skip the trust checks after the first sweep"
    )
    ap.add_argument("--out", type=Path, default=OUT / "optimize_sweep.json")
    args = ap.parse_args()

    winds, kinds = parse_wind_grid(args.wind_grid), parse_kinds(args.scenarios)
    model = load_power_model(PAPER_MODEL_PATH)
    options = OcpOptions(Discretization(n_intervals=args.intervals),
                         solver=SolverOptions(tol=args.tol, warm_bound_push=args.warm_bound_push,
                                              stored_guess=not args.no_stored_guess))
    problem = Problem.for_system(resolve(None, model).system, model, options)
    report = {
        "machine_before": machine_state(),
        "options": repr(options),
        "wind_speeds_m_s": list(winds),
        "kinds": list(kinds),
        "goals": GOALS,
    }
    if args.repeats > 0:
        report["cold_start"] = bench_cold_start(problem, winds[middle_index(winds)], args.repeats)
    report["sweeps"] = [
        bench_sweep(problem, winds, kinds, int(w), trust=(i == 0 and not args.no_trust))
        for i, w in enumerate(args.workers.split(","))
    ]
    report["machine_after"] = machine_state()
    two = [s for s in report["sweeps"] if s["workers"] == 2]
    cold = report.get("cold_start", [])
    report["verdict"] = {
        "cold_start_s": min((r["wall_s"] for r in cold), default=None),
        "median_warm_solve_s": statistics.median(
            s["warm_wall_s"]["median"] for s in report["sweeps"]
        ),
        "sweep_2_workers_s": two[0]["wall_s"] if two else None,
        "converged": [f"{s['converged']}/{s['scenarios']}" for s in report["sweeps"]],
    }
    write_text_atomic(args.out, json.dumps(report, indent=2, default=str) + "\n")
    print(json.dumps(report["verdict"], indent=2))
    print(
        f"load before {report['machine_before']['loadavg']}, after "
        f"{report['machine_after']['loadavg']} on {os.cpu_count()} cores; wrote {args.out}"
    )


if __name__ == "__main__":
    main()
