"""Adaptive wind grid against a 0.25 m/s grid, with real OCP solves.

Solves one scenario kind (default elec-lim) on a 0.25 m/s grid over the range
of the coarse grid (the reference), then refines the coarse grid with
:func:`energy.adaptive.refine_grid` (every solve warm-started from the nearest
solved speed) and prints the AEP of the coarse grid, of the refined grid and of
the reference at a Weibull site, with the number of solves each took. The
coarse grid's error is also the cost of linear interpolation on it (item 1).

Usage::

    .venv/bin/python benchmarks/adaptive_wind_grid.py --drive-model demo_out/fit/power_model.json
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from energy.adaptive import refine_grid
from energy.aep import aep_mwh
from energy.site import Weibull
from fitting.model_file import load_power_model
from optimize.kinds import KINDS
from optimize.model.kite_model import kite_dae
from optimize.paper_model import PAPER_MODEL_PATH
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.resolve import resolve
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start
from optimize.sweep_options import parse_wind_grid


class Solver:
    """``power(wind)`` for one kind, warm-started from the nearest solved speed; cached."""

    def __init__(self, model, kind: str, intervals: int) -> None:
        self.ocp = build_ocp(kite_dae(), model, OcpOptions(Discretization(n_intervals=intervals)),
        system=resolve(None, model).system)
        self.objective, self.limits = KINDS[kind].objective, KINDS[kind].drive_limits
        self.warm: dict[float, object] = {}
        self.cache: dict[float, float | None] = {}
        self.n_solves = 0

    def __call__(self, wind: float) -> float | None:
        wind = round(float(wind), 6)
        if wind in self.cache:
            return self.cache[wind]
        scenario = Scenario(wind, self.objective, self.limits)
        res = None
        if self.warm:
            src = min(self.warm, key=lambda w: abs(w - wind))
            res = solve(self.ocp, scenario, self.warm[src])
        if res is None or not res.success:
            res = start(self.ocp, scenario)
        self.n_solves += 1
        if res.success:
            self.warm[wind] = res.warm
        self.cache[wind] = res.avg_p_elec_w if res.success else None
        print(f"  {wind:6.3f} m/s  {res.status:<20} P_elec {res.avg_p_elec_w:9.2f} W", flush=True)
        return self.cache[wind]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--drive-model", default=str(PAPER_MODEL_PATH))
    ap.add_argument("--kind", default="elec-lim", choices=sorted(KINDS))
    ap.add_argument("--coarse", default="4:10:1.5")
    ap.add_argument("--fine-step", type=float, default=0.25)
    ap.add_argument("--weibull-k", type=float, default=2.0)
    ap.add_argument("--mean-speed", type=float, default=5.5)
    ap.add_argument("--intervals", type=int, default=40)
    args = ap.parse_args(argv)
    model = load_power_model(args.drive_model)
    site = Weibull.from_mean(args.weibull_k, args.mean_speed)
    coarse = parse_wind_grid(args.coarse)
    fine = tuple(np.round(np.arange(coarse[0], coarse[-1] + 1e-9, args.fine_step), 6))

    t0 = time.perf_counter()
    print(f"reference: {len(fine)} speeds every {args.fine_step} m/s ({args.kind})")
    ref_solver = Solver(model, args.kind, args.intervals)
    mid = fine[len(fine) // 2]
    for v in sorted(fine, key=lambda w: (abs(w - mid), w)):  # outwards from the middle
        ref_solver(v)
    ok = [v for v in fine if ref_solver.cache[v] is not None]
    ref = aep_mwh(np.array(ok), np.array([ref_solver.cache[v] for v in ok]), site)
    t_ref = time.perf_counter() - t0

    print(f"adaptive from {args.coarse}")
    solver = Solver(model, args.kind, args.intervals)
    t1 = time.perf_counter()
    coarse_p = [solver(v) for v in coarse]
    coarse_ok = [(v, p) for v, p in zip(coarse, coarse_p, strict=True) if p is not None]
    coarse_aep = aep_mwh(np.array([v for v, _ in coarse_ok]), np.array([p for _, p in coarse_ok]),
                         site)
    refined = refine_grid(solver, coarse, site)
    t_ad = time.perf_counter() - t1

    print(f"site: {site.describe()}; N = {args.intervals}")
    print(f"reference {args.fine_step} m/s grid: AEP {ref:.4f} MWh/yr, {len(fine)} solves "
          f"({len(fine) - len(ok)} failed), {t_ref:.0f} s")
    print(f"coarse {args.coarse}: AEP {coarse_aep:.4f} MWh/yr, error {coarse_aep / ref - 1:+.2%} "
          f"(the cost of linear interpolation on it)")
    grid = ", ".join(f"{w:g}" for w in refined.wind_speed_m_s)
    failed = f"; failed {refined.failed}" if refined.failed else ""
    print(f"adaptive: AEP {refined.aep_mwh:.4f} MWh/yr, error {refined.aep_mwh / ref - 1:+.2%}, "
          f"{solver.n_solves} solves, {t_ad:.0f} s; grid {grid}{failed}")
    return 0 if abs(refined.aep_mwh / ref - 1) <= 0.01 else 1


if __name__ == "__main__":
    raise SystemExit(main())
