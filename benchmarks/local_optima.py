"""How often a sweep lands on a local optimum, and what re-solving from the neighbour gains.

Usage::

    .venv/bin/python benchmarks/local_optima.py [--systems highwind,ap2,megawes]
        [--grids 4:10:1.5,4:13:1.5,4:13:3] [--workers 2] [--out benchmarks/out/local_optima]

Runs ``bench optimize`` (all four kinds, no claims) for each shipped system on its
wind grid, with the drive the command chooses for it, and counts from
``summary.parquet``: the converged scenarios, those whose average power or period
sat off their kind's smooth curve and were solved again from a neighbour
(``resolved_from``), and those where that found a better optimum
(``resolve_gain_w > 0``, the largest gain). Prints one line per system and per
re-solve, with the load average; writes ``OUT/local_optima.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import pandas as pd

from drivebench.cli import main as bench_main
from optimize.system.system import shipped_system_path


def run_system(name: str, grid: str, workers: int, out: Path) -> dict:
    """One sweep of a shipped system; the counts of its summary."""
    folder = out / name
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    code = bench_main(["optimize", "--system", str(shipped_system_path(name)), "--wind-grid",
                       grid, "--workers", str(workers), "--no-claims", "--out", str(folder)])
    wall = time.perf_counter() - t0
    summary = pd.read_parquet(folder / "summary.parquet")
    ok = summary[summary["success"]]
    resolved = ok[ok["resolved_from"] != ""]
    better = resolved[resolved["resolve_gain_w"] > 0]
    return {
        "system": name, "wind_grid": grid, "exit_code": code, "scenarios": len(summary),
        "converged": len(ok), "resolved": len(resolved), "better": len(better),
        "share_better": len(better) / len(ok) if len(ok) else float("nan"),
        "largest_gain_w": float(better["resolve_gain_w"].max()) if len(better) else 0.0,
        "resolves": [{"scenario": r.scenario, "from": r.resolved_from,
                      "gain_w": float(r.resolve_gain_w)} for r in resolved.itertuples()],
        "wall_time_s": wall, "driver_cpu_s": time.process_time() - c0,
        "load_average_start": load0, "load_average_end": os.getloadavg()[0],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", default="highwind,ap2,megawes")
    ap.add_argument("--grids", default="4:10:1.5,4:13:1.5,4:13:3",
                    help="one wind grid per system, comma-separated, in the same order")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/out/local_optima"))
    args = ap.parse_args()
    systems, grids = args.systems.split(","), args.grids.split(",")
    if len(systems) != len(grids):
        ap.error("--grids needs one grid per system")
    records = []
    for name, grid in zip(systems, grids, strict=True):
        rec = run_system(name, grid, args.workers, args.out)
        records.append(rec)
        print(f"{name} {grid}: {rec['converged']}/{rec['scenarios']} converged, "
              f"{rec['resolved']} re-solved from a neighbour, {rec['better']} better "
              f"({100 * rec['share_better']:.0f} % of converged), largest gain "
              f"{rec['largest_gain_w']:.1f} W; {rec['wall_time_s']:.0f} s wall, load "
              f"{rec['load_average_start']:.1f}-{rec['load_average_end']:.1f}")
        for r in rec["resolves"]:
            print(f"    {r['scenario']}: from {r['from']}, gain {r['gain_w']:.1f} W")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "local_optima.json").write_text(json.dumps(records, indent=2) + "\n")


if __name__ == "__main__":
    main()
