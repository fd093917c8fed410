"""Cold starts (homotopy, no stored guess) of the shipped systems across the wind range.

Usage::

    .venv/bin/python benchmarks/system_cold_starts.py [--systems highwind,ap2,megawes]
        [--winds 4,7,10,13] [--kind elec-lim] [--intervals 40] [--degree 4]

For every system (``optimize/data/systems/NAME.toml``) one OCP is built and each
wind speed is solved from the system's start loop through the homotopy. Each
system flies the drive its file names (:func:`optimize.system.drive_in_force.drive_in_force`):
highwind the paper's Table I drive, AP2 and MegAWES the paper's drive carried to
their rating by the similarity law. Prints per run: status, iterations,
wall time, P_elec, P_mech, period, active bounds and the slack-tether fraction,
with the load average; writes ``benchmarks/out/system_cold_starts.json``.

Goal: 12/12 converged, none with the period or tether on a bound the
file did not mean to bind, median cold start <= 20 s.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import time
from pathlib import Path

from optimize.kinds import KINDS
from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.sweep.outputs import MEANT_BOUNDS
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", default="highwind,ap2,megawes")
    ap.add_argument("--winds", default="4,7,10,13")
    ap.add_argument("--kind", default="elec-lim", choices=tuple(KINDS))
    ap.add_argument("--intervals", type=int, default=40)
    ap.add_argument("--degree", type=int, default=4)
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    objective, limits = KINDS[args.kind].objective, KINDS[args.kind].drive_limits
    runs = []
    for name in args.systems.split(","):
        system = load_system(shipped_system_path(name))
        drive, _ = drive_in_force(system)
        model = drive.power_model
        options = OcpOptions(Discretization(n_intervals=args.intervals, degree=args.degree),
                             solver=SolverOptions(stored_guess=False))
        ocp = build_ocp(kite_dae(*system.model_params()), model, options,
                        system=system.in_force(drive))
        print(f"{name}: start loop {ocp.loop}", flush=True)
        for wind in (float(w) for w in args.winds.split(",")):
            load = os.getloadavg()[0]
            t0 = time.perf_counter()
            res = solve_by_homotopy(ocp, Scenario(wind, objective, limits))
            wall = time.perf_counter() - t0
            unmeant = [b for b in res.active_bounds if b not in MEANT_BOUNDS]
            runs.append({
                "system": name, "wind_m_s": wind, "status": res.status, "success": res.success,
                "iterations": res.iterations, "wall_time_s": wall, "load_1min": load,
                "p_elec_w": res.avg_p_elec_w, "p_mech_w": res.avg_p_mech_w,
                "period_s": res.period_s, "active_bounds": list(res.active_bounds),
                "unmeant_bounds": unmeant, "slack_fraction": res.slack_fraction,
                "stages": [{k: s[k] for k in ("stage", "status", "iterations")}
                           for s in res.stages],
            })
            print(f"{name:<9} {wind:5.1f} m/s {res.status[:40]:<40} {res.iterations:4d} it "
                  f"{wall:6.1f} s (load {load:4.1f})  P_elec {res.avg_p_elec_w:12.1f} W  "
                  f"P_mech {res.avg_p_mech_w:12.1f} W  T {res.period_s:6.2f} s  "
                  f"bounds {','.join(res.active_bounds) or '-'}  slack "
                  f"{100 * res.slack_fraction:.1f} %", flush=True)
    ok = [r for r in runs if r["success"]]
    clean = [r for r in ok if not r["unmeant_bounds"]]
    median = statistics.median(r["wall_time_s"] for r in runs) if runs else float("nan")
    median_it = statistics.median(r["iterations"] for r in runs) if runs else float("nan")
    print(f"converged {len(ok)}/{len(runs)}; without an unmeant bound {len(clean)}/{len(runs)}; "
          f"median cold start {median:.1f} s, {median_it:.0f} iterations")
    out = Path(__file__).parent / "out"
    out.mkdir(exist_ok=True)
    (out / "system_cold_starts.json").write_text(json.dumps(runs, indent=2) + "\n")


if __name__ == "__main__":
    main()
