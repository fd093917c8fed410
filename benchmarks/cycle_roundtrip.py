"""Benchmark: the optimal cycle flown on the synthetic bench, against its truth.

Usage::

    .venv/bin/python benchmarks/cycle_roundtrip.py OPTIMIZE_OUT [--campaign raw_measurements]
        [--kinds elec-lim] [--seeds 20] [--cycles 10] [--theta-start-c 50] [--out DIR]

For every converged scenario of the given kinds in ``OPTIMIZE_OUT`` (the demo's: ``bench
run``'s sweep, or ``bench optimize`` on the demo's power model): ``bench cycle export``
in the frame of the campaign's motor-side session (motor_02: torque flange and encoder
on the motor side of the 1:3 gearbox), its integral of speed x torque against the
scenario's mechanical energy per cycle; then for each seed ``bench synth --cycle-run``
on the campaign's true drive, one ``bench ingest`` of all seeds' sessions and ``bench
cycle verify`` of each. Per scenario: the optimizer's electrical energy per cycle, the
power model's at the measured speed and torque, the measurement with its 95 % band, the
truth (the mean of the true energies of the kept cycles), and how many seeds' bands
cover the truth. Writes ``DIR/cycle_roundtrip_<theta>C.json`` and prints the table.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from bench.cycle_profile import BenchFrame
from bench.ingest.pipeline import ingest
from bench.synth.cycle_session import CycleRunSpec, write_cycle_run
from cycle.export import ExportOptions, export_cycle
from cycle.verify_command import verify_cycles
from optimize.sweep_folder import read_sweep_folder


def _scenario(opt: Path, scenario: str, campaign: Path, work: Path, seeds: int,
              cycles: int, theta_c: float) -> dict:
    frame = BenchFrame("motor", 3.0, 1, 1)  # motor_02's session.toml
    done = export_cycle(opt, scenario, work / "profile.csv",
                        ExportOptions(n_cycles=cycles, frame=frame),
                        bench_session=campaign / "motor_02")
    camp = work / "campaign"
    camp.mkdir()
    shutil.copy(campaign / "drive.toml", camp)
    truths = {}
    for seed in range(1, seeds + 1):
        spec = CycleRunSpec()
        run = dataclasses.replace(spec, session_id=f"run_{seed:02d}", seed=seed,
                                  bench=dataclasses.replace(spec.bench, theta_start_c=theta_c))
        truths[run.session_id] = write_cycle_run(camp, work / "profile.csv", run,
                                                 truth_path=campaign / "truth.json")
    ingest([camp], work / "store", progress=False, notify=lambda line: None)
    rows = []
    for sid, truth in truths.items():
        v = verify_cycles(work / "store", opt, work / f"verify_{sid}", session=sid)
        m, ids = v.record["means"], v.cycles["cycle_id"].to_numpy(int)
        true_e = float(np.mean(np.asarray(truth["cycles"]["e_elec_j"])[ids]))
        per_cycle = np.abs(v.cycles["e_elec_j"] - np.asarray(truth["cycles"]["e_elec_j"])[ids])
        rows.append({"seed": sid, "kept": len(ids), "measured_j": m["e_elec_j"],
                     "band_j": m["band_elec_j"], "model_j": m["e_elec_model_j"],
                     "true_j": true_e, "covered": abs(m["e_elec_j"] - true_e) <= m["band_elec_j"],
                     "cycles_within": int((per_cycle <= 2 * v.cycles["u_elec_j"]).sum()),
                     "verdict": v.verdict})
    h = done.profile.header
    true_mean = float(np.mean([r["true_j"] for r in rows]))
    meas_mean = float(np.mean([r["measured_j"] for r in rows]))
    return {"scenario": scenario, "period_s": h["period_s"],
            "e_mech_optimizer_j": h["e_mech_pred_j"], "e_mech_profile_j": h["e_mech_profile_j"],
            "e_mech_profile_error": done.e_mech_error,
            "e_elec_optimizer_j": h["e_elec_pred_j"],
            "e_elec_model_j": float(np.mean([r["model_j"] for r in rows])),
            "e_elec_measured_j": meas_mean,
            "band_j": float(np.mean([r["band_j"] for r in rows])), "e_elec_true_j": true_mean,
            "covered": sum(r["covered"] for r in rows), "seeds": len(rows),
            "cycles_within": sum(r["cycles_within"] for r in rows),
            "cycles_kept": sum(r["kept"] for r in rows), "runs": rows}


def _pct(a: float, b: float) -> str:
    return f"{100 * (a - b) / abs(b):+.1f} %"


def table(results: list[dict]) -> str:
    """The per-scenario table (markdown)."""
    lines = ["| scenario | T [s] | E_mech profile vs optimizer | optimizer [J] | model at "
             "measured [J] | measured [J] (95 %) | true [J] | optimizer vs true | model vs "
             "true | measured vs true | band covers truth | kept cycles within 2u |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        lines.append(
            f"| {r['scenario']} | {r['period_s']:.2f} | {100 * r['e_mech_profile_error']:.3f} % "
            f"| {r['e_elec_optimizer_j']:.0f} | {r['e_elec_model_j']:.0f} | "
            f"{r['e_elec_measured_j']:.0f} +- {r['band_j']:.0f} | {r['e_elec_true_j']:.0f} | "
            f"{_pct(r['e_elec_optimizer_j'], r['e_elec_true_j'])} | "
            f"{_pct(r['e_elec_model_j'], r['e_elec_true_j'])} | "
            f"{_pct(r['e_elec_measured_j'], r['e_elec_true_j'])} | "
            f"{r['covered']}/{r['seeds']} | {r['cycles_within']}/{r['cycles_kept']} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("optimize", type=Path, help="optimize output folder")
    parser.add_argument("--campaign", type=Path, default=Path("raw_measurements"))
    parser.add_argument("--kinds", default="elec-lim")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--cycles", type=int, default=10)
    parser.add_argument("--theta-start-c", type=float, default=CycleRunSpec().bench.theta_start_c,
                        help="the winding's temperature at the start of each run [degC]")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/out"))
    args = parser.parse_args()
    summary, _ = read_sweep_folder(args.optimize)
    kinds = args.kinds.split(",")
    todo = summary[summary["success"].astype(bool) & summary["kind"].isin(kinds)]
    results = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="cycle_roundtrip_") as tmp:
        for name in todo.sort_values("wind_speed_m_s")["scenario"].astype(str):
            work = Path(tmp) / name
            work.mkdir()
            try:
                results.append(_scenario(args.optimize, name, args.campaign, work, args.seeds,
                                         args.cycles, args.theta_start_c))
            except Exception as exc:  # noqa: BLE001 (one scenario's refusal is a result)
                results.append({"scenario": name, "refused": f"{type(exc).__name__}: {exc}"})
                print(f"{name}: refused: {exc}")
                continue
            r = results[-1]
            print(f"{name}: {r['covered']}/{r['seeds']} bands cover the truth "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    done = [r for r in results if "refused" not in r]
    print(table(done))
    args.out.mkdir(parents=True, exist_ok=True)
    name = f"cycle_roundtrip_{args.theta_start_c:g}C.json"
    (args.out / name).write_text(json.dumps(
        {"optimize": str(args.optimize), "seeds": args.seeds, "cycles": args.cycles,
         "theta_start_c": args.theta_start_c,
         "wall_time_s": time.perf_counter() - t0, "scenarios": results}, indent=1,
        default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
