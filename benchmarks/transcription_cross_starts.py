"""Do the two transcriptions find the same optima? Chains and cross-starts, side by side.

Usage::

    .venv/bin/python benchmarks/transcription_cross_starts.py [--kinds elec-lim,mech-lim]
        [--winds 7,5.5,4] [--tols 1e-6,1e-9] [--intervals 40]

For each IPOPT tolerance and kind, on the shipped paper system with its drive: the chain
of ``--winds`` (the first from the stored guess, each next one warm-started from the one
before, as ``bench optimize`` chains them) once with the collocation and once with the
condensed transcription; then each transcription's last optimum as the warm start of the
other's solve of the same scenario. Prints status, iterations, P_elec, P_mech and the
period of every last solve; writes ``benchmarks/out/transcription_cross_starts.json``.

How to read it: both transcriptions are one NLP, so they share their KKT points. Where the
chains end apart, a cross-start that stays at the point it was given shows that point to
be a local optimum of both (two optima, reached by two paths); a cross-start that
moves to its own chain's point shows a flat optimum that the tolerance leaves open, and
the tighter tolerance then brings both chains together.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from kernel.files import write_text_atomic
from optimize.kinds import KINDS
from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import Ocp, build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

OUT = Path(__file__).resolve().parent / "out"
TRANSCRIPTIONS = ("collocation", "condensed")


def ocps(tol: float, intervals: int) -> dict[str, Ocp]:
    """The paper system's OCP with each transcription at IPOPT tolerance ``tol``."""
    system = load_system()
    drive, _ = drive_in_force(system)
    out = {}
    for tr in TRANSCRIPTIONS:
        solver = SolverOptions(transcription=tr, tol=tol, acceptable_tol=100 * tol)
        options = OcpOptions(Discretization(n_intervals=intervals), solver=solver)
        out[tr] = build_ocp(kite_dae(*system.model_params()), drive.power_model, options,
                            system=system.in_force(drive))
    return out


def row(how: str, res) -> dict:
    """What one solve found."""
    return {"how": how, "status": res.status, "iterations": int(res.iterations),
            "p_elec_w": float(res.avg_p_elec_w), "p_mech_w": float(res.avg_p_mech_w),
            "period_s": float(res.period_s)}


def compare(kind: str, winds: list[float], problems: dict[str, Ocp]) -> list[dict]:
    """The chain with each transcription, then the cross-starts at the last wind."""
    rows, ends = [], {}
    for tr, ocp in problems.items():
        res = start(ocp, Scenario.of_kind(kind, winds[0]))
        for wind in winds[1:]:
            res = solve(ocp, Scenario.of_kind(kind, wind), res.warm)
        ends[tr] = res
        rows.append(row(f"{tr}, chain", res))
    for tr, ocp in problems.items():
        other = next(t for t in TRANSCRIPTIONS if t != tr)
        res = solve(ocp, Scenario.of_kind(kind, winds[-1]), ends[other].warm)
        rows.append(row(f"{tr}, from the {other} optimum", res))
    return rows


def main() -> None:
    """Parse options, run every tolerance and kind, print and write the rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="elec-lim,mech-lim")
    ap.add_argument("--winds", default="7,5.5,4", help="the chain, first to last")
    ap.add_argument("--tols", default="1e-6,1e-9", help="IPOPT tolerances (tol)")
    ap.add_argument("--intervals", type=int, default=40)
    ap.add_argument("--out", type=Path, default=OUT / "transcription_cross_starts.json")
    args = ap.parse_args()
    winds = [float(w) for w in args.winds.split(",")]
    kinds = [k for k in args.kinds.split(",") if k]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        ap.error(f"unknown kinds {unknown}; one of {', '.join(KINDS)}")
    report = {"winds": winds, "load_before": os.getloadavg(), "runs": []}
    t0 = time.perf_counter()
    for tol in (float(t) for t in args.tols.split(",")):
        problems = ocps(tol, args.intervals)
        for kind in kinds:
            for r in compare(kind, winds, problems):
                report["runs"].append({"tol": tol, "scenario": f"{kind}-{winds[-1]:g}", **r})
                print(f"tol {tol:g} {kind}-{winds[-1]:g} {r['how']:<34} {r['status']:<16} "
                      f"{r['iterations']:3d} it  P_elec {r['p_elec_w']:10.4f} W  "
                      f"P_mech {r['p_mech_w']:10.4f} W  T {r['period_s']:.4f} s", flush=True)
    report.update(wall_s=time.perf_counter() - t0, load_after=os.getloadavg())
    write_text_atomic(args.out, json.dumps(report, indent=2) + "\n")
    print(f"{report['wall_s']:.0f} s, load {report['load_before']} -> "
          f"{report['load_after']}; wrote {args.out}")


if __name__ == "__main__":
    main()
