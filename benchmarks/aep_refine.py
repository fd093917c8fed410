"""``bench aep --refine`` against a 0.25 m/s grid, per scenario kind.

Runs ``bench aep --refine`` on an optimize folder (default the demo's), then solves
each requested kind on a 0.25 m/s grid over the sweep's range with the sweep's own
model and OCP options (every solve warm-started from its inner neighbour, outwards
from the middle), and prints the electrical and mechanical AEP of the coarse sweep
grid, of the refined grid and of the 0.25 m/s grid, with the solves and wall time.

Usage::

    .venv/bin/python benchmarks/aep_refine.py --optimize demo_out/optimize --kinds elec-lim,mech-lim
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from drivebench.cli import main as bench_main
from energy.aep import aep_mwh
from energy.curve import read_optimize_run
from energy.refine import options_from_manifest, system_from_manifest
from energy.site import Weibull
from fitting.model_file import load_power_model
from optimize.kinds import KINDS
from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import build_ocp
from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start


def reference(ocp, kind: str, winds: np.ndarray) -> dict[float, tuple[float, float] | None]:
    """(P_elec, P_mech) [W] at every speed, outwards from the middle, warm-started."""
    objective, limits = KINDS[kind].objective, KINDS[kind].drive_limits
    mid = winds[len(winds) // 2]
    warm: dict[float, object] = {}
    out: dict[float, tuple[float, float] | None] = {}
    for v in sorted(winds, key=lambda w: (abs(w - mid), w)):
        sc = Scenario(float(v), objective, limits)
        res = None
        if warm:
            res = solve(ocp, sc, warm[min(warm, key=lambda w: abs(w - v))])
        if res is None or not res.success:
            res = start(ocp, sc)
        if res.success:
            warm[float(v)] = res.warm
        out[float(v)] = (res.avg_p_elec_w, res.avg_p_mech_w) if res.success else None
        print(f"  {kind} {v:6.3f} m/s {res.status:<20} P_elec {res.avg_p_elec_w:9.2f} W",
              flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--optimize", type=Path, default=Path("demo_out/optimize"))
    ap.add_argument("--kinds", default="elec-lim,mech-lim")
    ap.add_argument("--fine-step", type=float, default=0.25)
    ap.add_argument("--weibull-k", type=float, default=2.0)
    ap.add_argument("--mean-speed", type=float, default=5.5)
    args = ap.parse_args(argv)
    kinds = args.kinds.split(",")
    site = Weibull.from_mean(args.weibull_k, args.mean_speed)
    run = read_optimize_run(args.optimize)

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "aep"
        t0 = time.perf_counter()
        code = bench_main(["aep", "--optimize", str(args.optimize), "--out", str(out), "--refine",
                           "--weibull-k", str(args.weibull_k), "--mean-speed",
                           str(args.mean_speed), "--no-progress"])
        t_refine = time.perf_counter() - t0
        if code:
            return code
        doc = json.loads((out / "aep.json").read_text())["refine"]

    model = load_power_model(run.drive_model_path)
    ocp = build_ocp(kite_dae(), model, options_from_manifest(run.manifest, args.optimize),
                    system=system_from_manifest(run.manifest, args.optimize))
    lo, hi = run.manifest["wind_speeds_m_s"][0], run.manifest["wind_speeds_m_s"][-1]
    fine = np.round(np.arange(lo, hi + 1e-9, args.fine_step), 6)
    rows = []
    for kind in kinds:
        t1 = time.perf_counter()
        ref = reference(ocp, kind, fine)
        t_ref = time.perf_counter() - t1
        ok = [v for v in fine if ref[float(v)] is not None]
        p = np.array([ref[float(v)] for v in ok])
        k = doc["kinds"][kind]
        rows.append((kind, len(fine), len(fine) - len(ok), t_ref,
                     aep_mwh(np.array(ok), p[:, 0], site), aep_mwh(np.array(ok), p[:, 1], site),
                     k))
    print(f"\nsite {site.describe()}; optimize folder {args.optimize}; "
          f"bench aep --refine took {t_refine:.0f} s for all kinds "
          f"({doc['n_solved']} solves, {doc['executor']})")
    print("| kind | grid | solves | AEP el [MWh/yr] | err el | AEP mech [MWh/yr] | err mech |")
    print("|---|---|---|---|---|---|---|")
    worst = 0.0
    for kind, n, nfail, t_ref, ref_e, ref_m, k in rows:
        n_solves = sum(1 for s in k["solves"] if not s["cached"])
        print(f"| {kind} | {args.fine_step} m/s reference | {n} ({nfail} failed, {t_ref:.0f} s) | "
              f"{ref_e:.4f} | | {ref_m:.4f} | |")
        for label, e, m, s in (
                ("sweep grid", k["coarse_aep_elec_mwh"], k["coarse_aep_mech_mwh"], "0 extra"),
                ("refined " + ",".join(f"{r['wind_speed_m_s']:g}" for r in k["solves"]
                                       if r["role"] == "added"),
                 k["aep_elec_mwh"], k["aep_mech_mwh"],
                 f"{n_solves} extra ({k['n_added_failed']} failed)")):
            print(f"| {kind} | {label} | {s} | {e:.4f} | {e / ref_e - 1:+.2%} | {m:.4f} | "
                  f"{m / ref_m - 1:+.2%} |")
        worst = max(worst, abs(k["aep_elec_mwh"] / ref_e - 1), abs(k["aep_mech_mwh"] / ref_m - 1))
    return 0 if worst <= 0.01 else 1


if __name__ == "__main__":
    raise SystemExit(main())
