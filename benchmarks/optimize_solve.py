"""Measure the OCP: cold start (homotopy) and warm re-solves at 7 m/s and neighbours.

Usage::

    .venv/bin/python benchmarks/optimize_solve.py [--intervals 40] [--degree 4] [--repeat 1]
        [--reference-sigma]

Prints one log line per solver call, then a table of the scenarios (status,
iterations, wall and CPU time, average P_mech / P_elec, period). CPU time is
IPOPT's process time: on a shared machine the wall time can be several times
larger than the CPU time.
"""

from __future__ import annotations

import argparse
import json
import logging
import statistics
import time

from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.resolve import resolve
from optimize.solve import nlp_solver
from optimize.solve.solve import solve
from optimize.solve.starts.homotopy import HOMOTOPY_BOUND_PUSH, solve_by_homotopy

#: (label, scenario, index of the warm-start source in this list or None = cold start)
PLAN = [
    ("cold", Scenario(7.0, "mechanical", False), None),
    ("obj", Scenario(7.0, "electrical", False), 0),
    ("lim", Scenario(7.0, "electrical", True), 1),
    ("obj", Scenario(7.0, "mechanical", True), 2),
    ("wind", Scenario(8.5, "mechanical", False), 0),
    ("wind", Scenario(5.5, "mechanical", False), 0),
    ("wind", Scenario(8.5, "electrical", False), 1),
    ("wind", Scenario(5.5, "electrical", True), 2),
]


#: control scales of the reference implementation (rawesome pumping_poweropt.py)
REFERENCE_SIGMA = (10.0, 0.001, 0.8, 0.1)


def run_once(intervals: int, degree: int, reference_sigma: bool) -> list[dict]:
    t0 = time.perf_counter()
    options = OcpOptions(Discretization(n_intervals=intervals, degree=degree))
    if reference_sigma:
        options = options.replace(discretization={"control_sigma": REFERENCE_SIGMA})
    ocp = build_ocp(kite_dae(), paper_model(), options,
        system=resolve(None, paper_model()).system)
    nlp_solver.solver(ocp, False)
    nlp_solver.solver(ocp, True)
    nlp_solver.solver(ocp, True, HOMOTOPY_BOUND_PUSH)
    setup = time.perf_counter() - t0
    logging.info("build + solver creation %.1f s", setup)
    results, rows = [], []
    for label, scenario, source in PLAN:
        res = (solve_by_homotopy(ocp, scenario) if source is None
               else solve(ocp, scenario, results[source].warm))
        results.append(res)
        rows.append({
            "scenario": scenario.name, "start": label, "status": res.status,
            "iterations": res.iterations, "wall_time_s": round(res.wall_time_s, 2),
            "cpu_time_s": round(sum(s["cpu_time_s"] for s in res.stages), 2),
            "avg_p_mech_w": round(res.avg_p_mech_w, 1),
            "avg_p_elec_w": round(res.avg_p_elec_w, 1), "period_s": round(res.period_s, 3),
            "periodicity_error": res.periodicity_error, "setup_s": round(setup, 2),
            "stages": [
                {k: (round(v, 2) if isinstance(v, float) else v) for k, v in s.items()}
                for s in res.stages
            ],
        })
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--intervals", type=int, default=40)
    parser.add_argument("--degree", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--json", help="also write all rows to this JSON file")
    parser.add_argument("--reference-sigma", action="store_true",
                        help=f"regularize with the reference implementation's scales "
                             f"{REFERENCE_SIGMA}")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    runs = [run_once(args.intervals, args.degree, args.reference_sigma)
            for _ in range(args.repeat)]
    for i, rows in enumerate(runs):
        print(f"\nrun {i + 1}: N={args.intervals}, degree {args.degree}")
        print(f"{'scenario':<16}{'start':<6}{'status':<28}{'it':>5}{'wall s':>8}{'cpu s':>8}"
              f"{'P_mech W':>10}{'P_elec W':>10}{'T s':>7}")
        for r in rows:
            print(f"{r['scenario']:<16}{r['start']:<6}{r['status']:<28}{r['iterations']:>5}"
                  f"{r['wall_time_s']:>8.1f}{r['cpu_time_s']:>8.1f}{r['avg_p_mech_w']:>10.0f}"
                  f"{r['avg_p_elec_w']:>10.0f}{r['period_s']:>7.2f}")
    warm = [r for rows in runs for r in rows if r["start"] != "cold"]
    cold = [r for rows in runs for r in rows if r["start"] == "cold"]
    print(f"\ncold start: wall {[r['wall_time_s'] for r in cold]} s, "
          f"cpu {[r['cpu_time_s'] for r in cold]} s, it {[r['iterations'] for r in cold]}")
    print(f"warm solves: median wall {statistics.median(r['wall_time_s'] for r in warm):.1f} s, "
          f"max {max(r['wall_time_s'] for r in warm):.1f} s; median cpu "
          f"{statistics.median(r['cpu_time_s'] for r in warm):.1f} s; median it "
          f"{statistics.median(r['iterations'] for r in warm)}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(runs, fh, indent=1)


if __name__ == "__main__":
    main()
