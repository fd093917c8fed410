"""IPOPT iterations per warm solve: the neighbour's optimum against the tangential predictor.

Every warm start of the paper sweep's start graph (:func:`optimize.service.plan.plan_graph`,
4 kinds x 4:10:1.5, the seeds from the shipped stored guess or from elec-lim-7.0) is
solved four times from the same converged source, on the paper's OCP (default options):

* ``neighbour``: from the source's optimum as it is (today's warm start);
* ``predicted``: from the first-order prediction (``predictor_step = 1``,
  :mod:`optimize.solve.starts.predictor`);
* ``half``: half the predicted step (``predictor_step = 0.5``);
* ``own optimum``: from the scenario's own optimum (the ``neighbour`` solve's), the
  floor any start can reach with these warm-start settings.

The ``neighbour`` solves are the sources of later steps, as in the sweep. Iterations,
objectives (the same optimum?) and the tangent's time are recorded with the load.

``--accuracy N`` instead measures how far the first-order prediction is from the true
optimum, on N intervals: mech-free from its 7 m/s optimum to 7 + h m/s, the distance
``|w(7+h) - w(7) - dw|`` over ``|w(7+h) - w(7)|`` (scaled variables) per step h.

Run::

    .venv/bin/python benchmarks/warm_start_predictor.py
    .venv/bin/python benchmarks/warm_start_predictor.py --accuracy 10

Writes ``benchmarks/out/warm_start_predictor.json`` (or ``..._accuracy_N.json``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
from pathlib import Path

import numpy as np

from kernel.files import write_text_atomic
from optimize.kinds import DEFAULT_KINDS
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.resolve import resolve
from optimize.service.plan import plan_graph
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start
from optimize.solve.starts.predictor import tangent
from optimize.sweep_options import DEFAULT_WIND_GRID, parse_kinds, parse_wind_grid

OUT = Path(__file__).resolve().parent / "out"
VARIANTS = {"neighbour": 0.0, "predicted": 1.0, "half": 0.5}


#: the wind steps of ``--accuracy`` [m/s]
ACCURACY_STEPS = (0.1, 0.25, 0.5, 1.0, 1.5, -1.5)


def accuracy(n_intervals: int) -> dict:
    """The prediction's relative distance to the true optimum per wind step (see the
    module docstring)."""
    ocp = build_ocp(kite_dae(), paper_model(), OcpOptions(Discretization(n_intervals)),
        system=resolve(None, paper_model()).system)
    s0 = Scenario.of_kind("mech-free", 7.0)
    near = start(ocp, s0)
    if near.scenario != s0:  # the stored guess is elec-lim's: one warm step more
        near = solve(ocp, s0, near.warm)
    p0 = ocp.params(s0.parameters, s0.weights)
    b0 = ocp.bounds(drive_limits=False, fix_fictitious=True, period_s=None)
    rows = []
    for h in ACCURACY_STEPS:
        s1 = Scenario.of_kind("mech-free", 7.0 + h)
        far = solve(ocp, s1, near.warm)
        tg = tangent(ocp, near.warm.w, near.warm.lam_x, near.warm.lam_g, p0,
                     ocp.params(s1.parameters, s1.weights) - p0, b0)
        moved = far.warm.w - near.warm.w
        rows.append({"step_m_s": h, "moved": float(np.linalg.norm(moved)),
                     "ratio": float(np.linalg.norm(moved - tg.dw) / np.linalg.norm(moved)),
                     "iterations_from_neighbour": far.iterations, "tangent_s": tg.time_s})
        print(f"h {h:+5.2f} m/s: |moved| {rows[-1]['moved']:7.3f}, prediction error "
              f"{rows[-1]['ratio']:.3f} of it, {far.iterations} it from the neighbour, "
              f"tangent {tg.time_s:.2f} s", flush=True)
    return {"n_intervals": n_intervals, "steps": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wind-grid", default=DEFAULT_WIND_GRID)
    ap.add_argument("--scenarios", default=DEFAULT_KINDS)
    ap.add_argument("--accuracy", type=int, metavar="N", help="measure the prediction's "
                    "accuracy on N intervals instead")
    args = ap.parse_args()
    load = os.getloadavg()
    if args.accuracy:
        out = accuracy(args.accuracy)
        name = f"warm_start_predictor_accuracy_{args.accuracy}.json"
    else:
        out = sweep_starts(args.wind_grid, args.scenarios)
        name = "warm_start_predictor.json"
    out.update(load_before=load, load_after=os.getloadavg())
    OUT.mkdir(exist_ok=True)
    write_text_atomic(OUT / name, json.dumps(out, indent=1))
    print(f"load {load[0]:.1f} -> {out['load_after'][0]:.1f}; wrote {OUT / name}")


def sweep_starts(wind_grid: str, scenarios: str) -> dict:
    """Every warm start of the sweep's start graph from the four starts (module docstring)."""
    steps = plan_graph(parse_wind_grid(wind_grid), parse_kinds(scenarios))
    model = paper_model()
    ocps = {name: build_ocp(kite_dae(), model,
                            OcpOptions(solver=SolverOptions(predictor_step=step)),
        system=resolve(None, model).system)
            for name, step in VARIANTS.items()}
    solved, rows = {}, []
    for s in steps:
        sc = s.scenario
        if s.warm_from is None:
            solved[sc] = start(ocps["neighbour"], sc)
            continue
        source = solved[s.warm_from].warm
        row = {"scenario": s.name, "from": s.warm_from.name}
        for name, ocp in ocps.items():
            res = solve(ocp, sc, source, retry_cold=False)
            row[name] = {"iterations": res.iterations, "success": res.success,
                         "objective": res.objective, "wall_time_s": res.wall_time_s}
            if name == "neighbour":
                solved[sc] = res
        own = solve(ocps["neighbour"], sc, solved[sc].warm, retry_cold=False)
        row["own optimum"] = {"iterations": own.iterations, "success": own.success,
                              "objective": own.objective, "wall_time_s": own.wall_time_s}
        rows.append(row)
        print(s.name, "from", s.warm_from.name, " ".join(
            f"{k} {row[k]['iterations']}" for k in (*VARIANTS, "own optimum")), flush=True)
    summary = {k: {"median_iterations": statistics.median(r[k]["iterations"] for r in rows),
                   "total_iterations": sum(r[k]["iterations"] for r in rows),
                   "failed": sum(not r[k]["success"] for r in rows),
                   "total_wall_time_s": sum(r[k]["wall_time_s"] for r in rows),
                   "other_optimum": sum(abs(r[k]["objective"] - r["neighbour"]["objective"])
                                        > 1e-5 for r in rows)}
               for k in (*VARIANTS, "own optimum")}
    for k, v in summary.items():
        print(f"{k:12s} median {v['median_iterations']:5.1f} total {v['total_iterations']:4d} "
              f"failed {v['failed']} other optimum {v['other_optimum']} "
              f"wall {v['total_wall_time_s']:.1f} s")
    return {"wind_grid": wind_grid, "options": dataclasses.asdict(SolverOptions()),
            "summary": summary, "solves": rows}


if __name__ == "__main__":
    main()
