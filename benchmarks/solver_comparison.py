"""The NLP solvers and transcriptions on the same problems, back to back: IPOPT + MUMPS
and fatrop, each on the collocation NLP or the condensed one.

Usage::

    .venv/bin/python benchmarks/solver_comparison.py [--solvers ipopt,fatrop] [--workers 2]
        [--wind-grid 4:10:1.5] [--systems highwind,ap2,megawes] [--system-winds 7,10]

A solver name ``condensed-ipopt`` or ``condensed-fatrop`` runs that solver on the condensed
transcription (``--transcription condensed``,
:mod:`optimize.problem.transcriptions.condensed_nlp`) with the
interval functions in CasADi's virtual machine; ``condensed-ipopt+cc`` (or ``...fatrop+cc``)
with them compiled to C (:mod:`optimize.problem.transcriptions.codegen`; the first use
compiles them).

1. Profile: the warm solve of the stored guess's scenario from the stored guess (N = 40),
   with the solver's own time statistics (function evaluations, and fatrop's split);
   then the cold start of the same scenario (the homotopy, no stored guess), with the
   solver creation it needs.
2. The paper's 20 scenarios (4 kinds x ``--wind-grid``, the paper's Table I drive model,
   the shipped highwind system): the whole sweep on ``--workers`` processes with each
   solver, each chain started from the stored guess when it fits (else the homotopy),
   cut-in search and trust checks excluded (as ``optimize_sweep_benchmark.py``).
3. Each shipped system (``optimize/data/systems/*.toml``) with the drive its file names
   (:func:`optimize.system.drive_in_force.drive_in_force`): the elec-lim start
   at the first of ``--system-winds`` (stored guess when it fits, else the homotopy),
   then warm solves at the others.

Per solver: wall time, CPU time of the solver calls (summed over the workers),
iterations, CPU time per iteration, converged count; per scenario the status and the
difference of P_elec, P_mech and the period against the first solver (the reference),
and the largest difference. The machine load is recorded before and after: on a
shared machine compare CPU times and iterations, not wall times. Writes
``benchmarks/out/solver_comparison.json``.

Goals: the same optima as IPOPT (0.05 W, 0.01 s, same status), per-iteration time at
least 5x lower than IPOPT + MUMPS, the 20-scenario sweep at most 10 s on 2 idle workers.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import tempfile
import time
from pathlib import Path

import casadi as ca

from kernel.files import write_text_atomic
from optimize.kinds import DEFAULT_KINDS
from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.problem.transcriptions.derivatives import nlp_derivatives, whole_derivatives
from optimize.service import Problem, SweepTasks, run_sweep
from optimize.service.executors import open_executor
from optimize.service.plan import plan_graph
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.sweep_options import DEFAULT_WIND_GRID, parse_kinds, parse_wind_grid
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system

OUT = Path(__file__).resolve().parent / "out"
GOALS = {"optimum_w": 0.05, "period_s": 0.01, "per_iteration_speedup": 5.0,
         "sweep_2_workers_s": 10.0}


def solver_options(name: str, max_iter: int) -> SolverOptions:
    """The solver options of a name of ``--solvers`` (``[condensed-]ipopt|fatrop[+cc]``)."""
    base, cc, _ = name.partition("+cc")
    transcription, _, solver = base.rpartition("-")
    return SolverOptions(solver=solver, max_iter=max_iter,
                         transcription=transcription or "collocation", codegen=bool(cc))


def load() -> list[float]:
    """Load averages (1, 5, 15 min)."""
    return [round(x, 2) for x in os.getloadavg()]


def record(name: str, res) -> dict:
    """Status, optimum and solver effort of one OcpResult."""
    ok = bool(res.success)
    return {
        "scenario": name, "status": res.status, "success": ok,
        "iterations": int(res.iterations),
        "cpu_s": float(sum(s.get("cpu_time_s", 0.0) for s in res.stages)),
        "solver_wall_s": float(res.wall_time_s),
        "p_elec_w": float(res.avg_p_elec_w) if ok else None,
        "p_mech_w": float(res.avg_p_mech_w) if ok else None,
        "period_s": float(res.period_s) if ok else None,
    }


def totals(rows: list[dict], wall_s: float) -> dict:
    """Wall time, summed CPU and iterations, CPU per iteration, converged count."""
    it = sum(r["iterations"] for r in rows)
    cpu = sum(r["cpu_s"] for r in rows)
    return {"wall_s": wall_s, "cpu_s": cpu, "iterations": it,
            "cpu_per_iteration_s": cpu / it if it else None,
            "converged": sum(r["success"] for r in rows), "solves": len(rows)}


def paper_sweep(solver: str, winds, kinds, workers: int, intervals: int, max_iter: int) -> dict:
    """The paper scenarios' sweep with one solver."""
    system = load_system()
    drive, _ = drive_in_force(system)
    options = OcpOptions(Discretization(n_intervals=intervals),
                         solver=solver_options(solver, max_iter))
    problem = Problem.for_system(system.in_force(drive), drive.power_model, options)
    load_before = load()
    t0 = time.perf_counter()
    with open_executor(workers) as handle:
        result = run_sweep(SweepTasks(problem, plan_graph(winds, kinds), selected=kinds), handle)
    wall = time.perf_counter() - t0
    rows = []
    for o in result.outcomes:
        if o.result is not None:
            rows.append(record(o.name, o.result))
        else:
            rows.append({"scenario": o.name, "status": o.status, "success": False,
                         "iterations": 0, "cpu_s": 0.0, "solver_wall_s": 0.0,
                         "p_elec_w": None, "p_mech_w": None, "period_s": None})
    out = {"solver": solver, "scenarios": rows, **totals(rows, wall),
           "build_s": [c.build_time_s for c in result.chains],
           "load_before": load_before, "load_after": load()}
    print(f"{solver}: paper sweep {out['converged']}/{out['solves']} converged, wall "
          f"{wall:.1f} s, CPU {out['cpu_s']:.1f} s, {out['iterations']} iterations, "
          f"{1000 * (out['cpu_per_iteration_s'] or 0):.0f} ms CPU per iteration "
          f"(load {load_before} -> {out['load_after']})", flush=True)
    return out


def system_runs(solver: str, systems: list[str], winds: list[float], intervals: int,
                max_iter: int) -> dict:
    """Start and warm solves of elec-lim on each shipped system with one solver."""
    rows, t_all = [], time.perf_counter()
    for name in systems:
        system = load_system(shipped_system_path(name))
        drive, _ = drive_in_force(system)
        options = OcpOptions(Discretization(n_intervals=intervals),
                             solver=solver_options(solver, max_iter))
        t0, c0 = time.perf_counter(), time.process_time()
        ocp = build_ocp(kite_dae(*system.model_params()), drive.power_model, options,
                        system=system.in_force(drive))
        res = start(ocp, Scenario(winds[0], "electrical", True))
        rows.append({**record(f"{name}-elec-lim-{winds[0]:g}", res), "start": res.start,
                     "wall_s": time.perf_counter() - t0,
                     "process_cpu_s": time.process_time() - c0})
        warm = res.warm if res.success else None
        for wind in winds[1:]:
            t0, c0 = time.perf_counter(), time.process_time()
            res = solve(ocp, Scenario(wind, "electrical", True), warm)
            rows.append({**record(f"{name}-elec-lim-{wind:g}", res), "start": res.start,
                         "wall_s": time.perf_counter() - t0,
                         "process_cpu_s": time.process_time() - c0})
            warm = res.warm if res.success else warm
        for r in rows[-len(winds):]:
            print(f"{solver:<7} {r['scenario']:<24} {r['status'][:34]:<34} {r['iterations']:4d} it"
                  f" {r['cpu_s']:7.1f} s CPU  P_elec {r['p_elec_w'] or float('nan'):12.1f} W  "
                  f"T {r['period_s'] or float('nan'):6.2f} s  ({r['start']})", flush=True)
    return {"solver": solver, "runs": rows, **totals(rows, time.perf_counter() - t_all)}


IPOPT_TIMERS = {"OverallAlgorithm": "total", "StdAugSystemSolverMultiSolve": "linear_solves",
                "LinearSystemBackSolve": "back_solves", "Function Evaluations": "functions"}


@contextlib.contextmanager
def ipopt_timing():
    """IPOPT's own timing statistics of the solves inside the block (CPU s per timer of
    :data:`IPOPT_TIMERS`, summed): the IPOPT solvers created inside write them to a file.

    ``linear_solves`` is MUMPS (factorization and back solves); ``back_solves`` its
    back solves alone. Wraps ``casadi.nlpsol`` for the block, so only solvers created
    inside it are timed.
    """
    split: dict[str, float] = {}
    original = ca.nlpsol
    with tempfile.TemporaryDirectory() as tmp:
        logs: list[Path] = []

        def nlpsol(name, plugin, nlp, opts):
            if plugin == "ipopt":
                logs.append(Path(tmp) / f"ipopt{len(logs)}.txt")
                opts = {**opts, "ipopt": {**opts["ipopt"], "print_timing_statistics": "yes",
                                          "output_file": str(logs[-1]),
                                          "file_print_level": 3}}
            return original(name, plugin, nlp, opts)

        ca.nlpsol = nlpsol
        try:
            yield split
        finally:
            ca.nlpsol = original
        for log in logs:
            for line in log.read_text().splitlines():
                name = line.split(".")[0].strip()
                if name in IPOPT_TIMERS and ":" in line:
                    cpu = float(line.split(":")[1].split()[0])
                    split[IPOPT_TIMERS[name]] = split.get(IPOPT_TIMERS[name], 0.0) + cpu


def derivative_build_cpu_s(ocp) -> dict[str, float]:
    """CPU seconds to build IPOPT's derivative functions point by point and whole."""
    c0 = time.process_time()
    nlp_derivatives(ocp.transcription)
    c1 = time.process_time()
    whole_derivatives(ocp.nlp)
    return {"point_by_point": c1 - c0, "whole": time.process_time() - c1}


def profile(solver: str, max_iter: int) -> dict:
    """Where one solve's time goes: the warm solve of the stored guess's own scenario
    (elec-lim-7.0, N = 40) from the stored guess, with the solver's own statistics."""
    from optimize.solve import nlp_solver
    from optimize.solve.starts import stored_guess

    system = load_system()
    drive, _ = drive_in_force(system)
    options = OcpOptions(solver=solver_options(solver, max_iter))
    t0, c0 = time.perf_counter(), time.process_time()
    ocp = build_ocp(kite_dae(*system.model_params()), drive.power_model, options,
                    system=system.in_force(drive))
    build = (time.perf_counter() - t0, time.process_time() - c0)
    guess, why = stored_guess.load(ocp)
    deriv = derivative_build_cpu_s(ocp) if solver == "ipopt" else {}
    with ipopt_timing() as split:
        t0, c0 = time.perf_counter(), time.process_time()
        nlp_solver.solver(ocp, True)
        create = (time.perf_counter() - t0, time.process_time() - c0)
        res = solve(ocp, stored_guess.GUESS_SCENARIO, guess, retry_cold=False)
    stats = nlp_solver.solver(ocp, True).stats()
    out = {"solver": solver, "layout": ocp.layout.name, "variables": ocp.layout.n_w,
           "rows": ocp.layout.n_g, "build_wall_cpu_s": build, "create_wall_cpu_s": create,
           "guess": why, **record(stored_guess.GUESS_SCENARIO.name, res),
           "derivative_build_cpu_s": deriv, "ipopt_timing_cpu_s": split,
           "t_proc_s": {k[7:]: v for k, v in stats.items() if k.startswith("t_proc_")},
           "t_wall_s": {k[7:]: v for k, v in stats.items() if k.startswith("t_wall_")}}
    out["cpu_per_iteration_s"] = out["cpu_s"] / max(out["iterations"], 1)
    t0, c0 = time.perf_counter(), time.process_time()
    cold = solve_by_homotopy(ocp, stored_guess.GUESS_SCENARIO)
    out["cold_start"] = {**record(stored_guess.GUESS_SCENARIO.name, cold),
                         "wall_s": time.perf_counter() - t0,
                         "process_cpu_s": time.process_time() - c0}
    if "fatrop" in stats:
        out["fatrop"] = stats["fatrop"]
        out["stages"] = {"N": stats["N"], "nx": sorted(set(stats["nx"])),
                         "nu": sorted(set(stats["nu"])), "ng": sorted(set(stats["ng"]))}
    print(f"{solver}: warm solve of the stored guess: {res.status}, {res.iterations} it, "
          f"{out['cpu_s']:.2f} s CPU ({1000 * out['cpu_per_iteration_s']:.0f} ms per "
          f"iteration), function evaluations {sum(out['t_proc_s'].values()):.2f} s CPU; "
          f"build {build[1]:.1f} s CPU, solver creation {create[1]:.1f} s CPU", flush=True)
    c = out["cold_start"]
    print(f"{solver}: cold start (homotopy): {c['status']}, {c['iterations']} it, "
          f"{c['process_cpu_s']:.1f} s CPU, {c['wall_s']:.1f} s wall, "
          f"P_elec {c['p_elec_w'] or float('nan'):.4f} W", flush=True)
    if split:
        it = max(out["iterations"], 1)
        print(f"{solver}: IPOPT timers per iteration (ms CPU): "
              + ", ".join(f"{k} {1000 * v / it:.1f}" for k, v in split.items()), flush=True)
    if deriv:
        print(f"{solver}: derivatives built point by point {deriv['point_by_point']:.2f} s CPU, "
              f"whole NLP {deriv['whole']:.2f} s CPU", flush=True)
    return out


def differences(ref: list[dict], other: list[dict]) -> dict:
    """Per scenario the differences to the reference; the largest; status mismatches."""
    by_name = {r["scenario"]: r for r in other}
    per, worst = [], {"p_w": 0.0, "period_s": 0.0}
    for r in ref:
        o = by_name.get(r["scenario"])
        if o is None:
            continue
        row = {"scenario": r["scenario"], "status_ref": r["status"], "status": o["status"],
               "same_status": r["success"] == o["success"]}
        if r["success"] and o["success"]:
            row.update(dp_elec_w=o["p_elec_w"] - r["p_elec_w"],
                       dp_mech_w=o["p_mech_w"] - r["p_mech_w"],
                       dperiod_s=o["period_s"] - r["period_s"])
            worst["p_w"] = max(worst["p_w"], abs(row["dp_elec_w"]), abs(row["dp_mech_w"]))
            worst["period_s"] = max(worst["period_s"], abs(row["dperiod_s"]))
        per.append(row)
    return {"per_scenario": per, "max_abs": worst,
            "status_mismatches": [p["scenario"] for p in per if not p["same_status"]]}


def main() -> None:
    """Parse options, run both parts for every solver, compare, write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solvers", default="ipopt,fatrop", help="first one is the reference")
    ap.add_argument("--wind-grid", default=DEFAULT_WIND_GRID)
    ap.add_argument("--scenarios", default=DEFAULT_KINDS)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--intervals", type=int, default=40)
    ap.add_argument("--systems", default="highwind,ap2,megawes",
                    help="shipped systems to start and warm-solve ('' skips the part)")
    ap.add_argument("--system-winds", default="7,10")
    ap.add_argument("--no-sweep", action="store_true", help="skip the paper sweep")
    ap.add_argument("--no-profile", action="store_true",
                    help="skip the profile of one warm solve from the stored guess")
    ap.add_argument("--max-iter", type=int, default=SolverOptions.max_iter,
                    help="iteration limit per solver call, both solvers")
    ap.add_argument("--out", type=Path, default=OUT / "solver_comparison.json")
    args = ap.parse_args()
    solvers = args.solvers.split(",")
    winds, kinds = parse_wind_grid(args.wind_grid), parse_kinds(args.scenarios)
    systems = [s for s in args.systems.split(",") if s]
    system_winds = [float(w) for w in args.system_winds.split(",")]
    report = {"machine": {"nproc": os.cpu_count(), "load_before": load()}, "goals": GOALS,
              "max_iter": args.max_iter,
              "solvers": solvers, "sweep": {}, "systems": {}, "profile": {}}
    for solver in solvers:
        if not args.no_profile:
            report["profile"][solver] = profile(solver, args.max_iter)
        if not args.no_sweep:
            report["sweep"][solver] = paper_sweep(solver, winds, kinds, args.workers,
                                                  args.intervals, args.max_iter)
        if systems:
            report["systems"][solver] = system_runs(solver, systems, system_winds,
                                                    args.intervals, args.max_iter)
        # each solver's figures as soon as they are measured: a long run stopped
        # part-way keeps them
        write_text_atomic(args.out, json.dumps(report, indent=2, default=str) + "\n")
    ref = solvers[0]
    verdict = {}
    for solver in solvers[1:]:
        v = {}
        for part, key in (("sweep", "scenarios"), ("systems", "runs")):
            if solver in report[part]:
                v[part] = differences(report[part][ref][key], report[part][solver][key])
                a, b = report[part][ref], report[part][solver]
                if a["cpu_per_iteration_s"] and b["cpu_per_iteration_s"]:
                    v[part]["per_iteration_speedup"] = (a["cpu_per_iteration_s"]
                                                        / b["cpu_per_iteration_s"])
                v[part]["wall_s"] = {ref: a["wall_s"], solver: b["wall_s"]}
                v[part]["cpu_s"] = {ref: a["cpu_s"], solver: b["cpu_s"]}
                v[part]["iterations"] = {ref: a["iterations"], solver: b["iterations"]}
        verdict[solver] = v
    report["verdict"] = verdict
    report["machine"]["load_after"] = load()
    write_text_atomic(args.out, json.dumps(report, indent=2, default=str) + "\n")
    for solver, v in verdict.items():
        for part, d in v.items():
            print(f"{part}: {solver} vs {ref}: largest |dP| {d['max_abs']['p_w']:.4f} W, "
                  f"|dT| {d['max_abs']['period_s']:.4f} s, status mismatches "
                  f"{d['status_mismatches'] or 'none'}; CPU per iteration "
                  f"{ref} / {solver} = {d.get('per_iteration_speedup', float('nan')):.2f}; "
                  f"wall {d['wall_s']}, CPU {d['cpu_s']}, iterations {d['iterations']}")
    print(f"load {report['machine']['load_before']} -> {report['machine']['load_after']} on "
          f"{os.cpu_count()} cores; wrote {args.out}")


if __name__ == "__main__":
    main()
