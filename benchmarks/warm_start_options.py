"""IPOPT iterations per warm solve under other warm-start settings (issue 40's 12-iteration
target).

Every warm start of the paper sweep's start graph (:func:`optimize.service.plan.plan_graph`,
4 kinds x 4:10:1.5, the seeds from the shipped stored guess) is solved from the same
converged source (the neighbour's optimum, solved once with today's settings) under each
variant of IPOPT's warm-start options:

* ``today``: ``mu_init`` 1e-4, the bound pushes 1e-2 (:class:`SolverOptions`' defaults);
* ``adaptive``: IPOPT's adaptive barrier update (``mu_strategy adaptive``);
* ``adaptive-push3``: the same with the bound pushes at 1e-3;
* ``btf100``: ``barrier_tol_factor`` 100 (each barrier level ends 10x sooner);
* ``mu5-push3``: ``mu_init`` 1e-5, pushes 1e-3;
* ``kappa05``: ``mu_linear_decrease_factor`` 0.05 (the barrier falls faster);
* ``tol5``: ``tol`` 1e-5 instead of 1e-6 (the last barrier level is 1e-6, not 1e-7);
* ``acceptable2``: ``acceptable_iter`` 2 and ``acceptable_tol`` 1e-5 (IPOPT stops after
  2 iterates within 1e-5 instead of 5 within 1e-4, or at ``tol``);
* ``fhp3``, ``fhp6``: ``first_hessian_perturbation`` 1e-3 or 1e-6 instead of 1e-4 (the
  first regularization tried when the KKT matrix has the wrong inertia);
* ``inc3``: ``perturb_inc_fact_first`` and ``perturb_inc_fact`` 3 instead of 100 and 8
  (smaller increases of that regularization);
* ``mu3``, ``mu5``: ``mu_init`` 1e-3 or 1e-5 with today's bound pushes.

The options the product does not expose reach IPOPT through a wrapper of
``casadi.nlpsol`` that adds them to a warm solver's options (this script only). Per
variant: the median and total iterations, failures, the summed solver wall time and the
largest change of the optimum's objective against ``today`` in W (the objective is
scaled by the OCP's power scale).

Run::

    .venv/bin/python benchmarks/warm_start_options.py [--variants today,adaptive]

Writes ``benchmarks/out/warm_start_options.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
from pathlib import Path

import casadi as ca

from kernel.files import write_text_atomic
from optimize.kinds import DEFAULT_KINDS
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import OcpOptions, SolverOptions
from optimize.resolve import resolve
from optimize.service.plan import plan_graph
from optimize.solve import nlp_solver
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start
from optimize.sweep_options import DEFAULT_WIND_GRID, parse_kinds, parse_wind_grid

OUT = Path(__file__).resolve().parent / "out"
#: name -> (extra IPOPT options of a warm solve, warm_mu_init, warm_bound_push)
VARIANTS = {
    "today": ({}, 1e-4, 1e-2),
    "adaptive": ({"mu_strategy": "adaptive"}, 1e-4, 1e-2),
    "adaptive-push3": ({"mu_strategy": "adaptive"}, 1e-4, 1e-3),
    "btf100": ({"barrier_tol_factor": 100.0}, 1e-4, 1e-2),
    "mu5-push3": ({}, 1e-5, 1e-3),
    "kappa05": ({"mu_linear_decrease_factor": 0.05}, 1e-4, 1e-2),
    "tol5": ({"tol": 1e-5}, 1e-4, 1e-2),
    "acceptable2": ({"acceptable_iter": 2, "acceptable_tol": 1e-5}, 1e-4, 1e-2),
    "fhp3": ({"first_hessian_perturbation": 1e-3}, 1e-4, 1e-2),
    "fhp6": ({"first_hessian_perturbation": 1e-6}, 1e-4, 1e-2),
    "inc3": ({"perturb_inc_fact_first": 3.0, "perturb_inc_fact": 3.0}, 1e-4, 1e-2),
    "mu3": ({}, 1e-3, 1e-2),
    "mu5": ({}, 1e-5, 1e-2),
}


class _WarmOptions:
    """Wraps ``casadi.nlpsol`` as nlp_solver calls it: a warm IPOPT solver gets
    :attr:`extra` added to its options."""

    def __init__(self) -> None:
        self.extra: dict = {}
        self.nlpsol = ca.nlpsol

    def __call__(self, name, plugin, nlp, opts):  # noqa: D102 (casadi.nlpsol)
        if plugin == "ipopt" and opts["ipopt"].get("warm_start_init_point") == "yes":
            opts = {**opts, "ipopt": {**opts["ipopt"], **self.extra}}
        return self.nlpsol(name, plugin, nlp, opts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variants", default=",".join(VARIANTS))
    args = ap.parse_args()
    names = [v for v in args.variants.split(",") if v]
    wrapper = _WarmOptions()
    nlp_solver.ca.nlpsol = wrapper
    steps = plan_graph(parse_wind_grid(DEFAULT_WIND_GRID), parse_kinds(DEFAULT_KINDS))
    model = paper_model()
    base = build_ocp(kite_dae(), model, OcpOptions(),
        system=resolve(None, model).system)
    solved = {}
    for s in steps:  # the sources, with today's settings
        solved[s.scenario] = (start(base, s.scenario) if s.warm_from is None
                              else solve(base, s.scenario, solved[s.warm_from].warm,
                                         retry_cold=False))
    load = os.getloadavg()
    out = {"wind_grid": DEFAULT_WIND_GRID, "load_before": load, "variants": {}}
    for name in names:
        extra, mu, push = VARIANTS[name]
        wrapper.extra = extra
        ocp = build_ocp(kite_dae(), model, OcpOptions(
            solver=SolverOptions(warm_mu_init=mu, warm_bound_push=push)),
        system=resolve(None, model).system)
        rows = []
        for s in steps:
            if s.warm_from is None:
                continue
            r = solve(ocp, s.scenario, solved[s.warm_from].warm, retry_cold=False)
            rows.append({"scenario": s.name, "iterations": r.iterations, "success": r.success,
                         "wall_time_s": r.wall_time_s,
                         "d_objective_w": abs(r.objective - solved[s.scenario].objective)
                         * base.formulation.objective_scale})
        its = [r["iterations"] for r in rows]
        out["variants"][name] = {
            "extra": extra, "warm_mu_init": mu, "warm_bound_push": push,
            "median_iterations": statistics.median(its), "total_iterations": sum(its),
            "failed": sum(not r["success"] for r in rows),
            "wall_time_s": sum(r["wall_time_s"] for r in rows),
            "max_d_objective_w": max(r["d_objective_w"] for r in rows), "solves": rows}
        v = out["variants"][name]
        print(f"{name:15s} median {v['median_iterations']:5.1f} total {v['total_iterations']:4d} "
              f"failed {v['failed']} wall {v['wall_time_s']:6.1f} s "
              f"max |d objective| {v['max_d_objective_w']:.3g} W", flush=True)
    out["load_after"] = os.getloadavg()
    OUT.mkdir(exist_ok=True)
    write_text_atomic(OUT / "warm_start_options.json", json.dumps(out, indent=1))
    print(f"load {load[0]:.1f} -> {out['load_after'][0]:.1f}; wrote "
          f"{OUT / 'warm_start_options.json'}")


if __name__ == "__main__":
    main()
