"""The first solve on a mesh other than the stored guess's: the guess interpolated onto
it against the homotopy.

For each case (intervals, degree, scenario kind, wind speed) on the paper's kite and
drive model, solves the scenario with :func:`optimize.solve.starts.cold.start` (the
stored guess, checked on its own 40 x 4 mesh and interpolated onto the case's,
:func:`optimize.solve.starts.stored_guess.interpolated`) and with the homotopy
(:func:`optimize.solve.starts.homotopy.solve_by_homotopy`), and prints both: status,
iterations, wall time, P_elec, P_mech and the period.

Run::

    .venv/bin/python benchmarks/interpolated_guess.py [--cases 20x4:elec-lim:10,10x4:mech-free:7]
"""

from __future__ import annotations

import argparse
import os
import time

from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.resolve import resolve
from optimize.solve.starts.cold import start
from optimize.solve.starts.homotopy import solve_by_homotopy

CASES = ("20x4:elec-lim:10,10x4:mech-free:7,10x4:elec-lim:7,14x3:elec-free:10,"
         "80x4:elec-lim:7,8x4:mech-lim:7")


def _line(name: str, res, wall_s: float) -> str:
    return (f"{name} {res.status} {res.iterations} it {wall_s:.1f} s, P_elec "
            f"{res.avg_p_elec_w:.3f} W, P_mech {res.avg_p_mech_w:.3f} W, T {res.period_s:.3f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default=CASES)
    args = ap.parse_args()
    print(f"load {os.getloadavg()[0]:.1f}")
    for case in args.cases.split(","):
        mesh, kind, wind = case.split(":")
        n, degree = (int(v) for v in mesh.split("x"))
        ocp = build_ocp(kite_dae(), paper_model(),
                        OcpOptions(Discretization(n_intervals=n, degree=degree)),
        system=resolve(None, paper_model()).system)
        scenario = Scenario.of_kind(kind, float(wind))
        print(f"{n} x {degree}, {scenario.name}:", flush=True)
        for name, how in (("  interpolated guess:", start),
                          ("  homotopy:          ", solve_by_homotopy)):
            t0 = time.perf_counter()
            res = how(ocp, scenario)
            print(_line(name, res, time.perf_counter() - t0), flush=True)
    print(f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
