"""The solve service's own cost per solve: the chain loop with a solver that costs nothing.

Runs the planned one-chain sweep of ``bench optimize`` (4 kinds x 4:10:1.5 m/s, local
optima re-solve and cut-in searches on, as the command runs it) through
:func:`optimize.service.run_chain` with a stand-in backend whose solves return at once
(a 161-point cycle, as 40 intervals of degree 4 give), and prints the CPU time per
solve: what the service adds to each IPOPT solve.

Run::

    .venv/bin/python benchmarks/service_overhead.py --repeats 200
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from optimize.kinds import KINDS
from optimize.problem.scenario import Scenario
from optimize.service import ChainTask, Problem, run_chain
from optimize.service.plan import chain_steps
from optimize.sweep_options import parse_wind_grid

TRAJECTORY = pd.DataFrame({"weight": np.full(161, 1 / 161),
                           "speed_rpm": np.linspace(-900.0, 900.0, 161),
                           "torque_nm": np.linspace(0.0, 78.0, 161)})


@dataclass(frozen=True)
class Result:
    """A converged solve's fields the service reads."""

    status: str
    success: bool
    iterations: int
    wall_time_s: float
    avg_p_elec_w: float
    avg_p_mech_w: float
    period_s: float
    trajectory: object
    warm: object
    start: str = "warm start"


class FreeBackend:
    """Every solve converges at once: P = -100 w^2 W (generated at every speed)."""

    def build(self, problem: Problem) -> str:  # noqa: D102 (Backend.build)
        return "ocp"

    def solve(self, ocp: str, scenario: Scenario, warm: object) -> Result:  # noqa: D102
        return self.cold_start(ocp, scenario)

    def cold_start(self, ocp: str, scenario: Scenario) -> Result:  # noqa: D102
        wind = scenario.wind_speed_m_s
        return Result("Solve_Succeeded", True, 20, 0.0, -100.0 * wind**2, -120.0 * wind**2,
                      5.0, TRAJECTORY, wind)

    def check(self, ocp: str, result: Result, name: str) -> None:  # noqa: D102 (Backend.check)
        return None


def main() -> None:
    """Time the chain loop and print microseconds of CPU per solve."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wind-grid", default="4:10:1.5")
    ap.add_argument("--repeats", type=int, default=200)
    args = ap.parse_args()
    task = ChainTask(Problem(None, None, None, "stand-in"),
                     chain_steps(tuple(KINDS), parse_wind_grid(args.wind_grid)),
                     backend=FreeBackend(), resolve=True, cut_in_kinds=("elec-lim", "mech-lim"))
    run_chain(task)  # imports and first-call costs out of the timing
    t0 = time.process_time()
    for _ in range(args.repeats):
        out = run_chain(task)
    cpu = time.process_time() - t0
    n = len(out.records)
    print(f"{n} solves per chain, {args.repeats} chains: "
          f"{1e6 * cpu / (args.repeats * n):.0f} us CPU per solve")


if __name__ == "__main__":
    main()
