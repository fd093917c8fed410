"""The shipped systems with the drives their files name: every kind, a wind grid, a table.

Usage::

    .venv/bin/python benchmarks/system_drives.py [--systems ap2,megawes] [--wind-grid 4:13:3]
        [--from DIR]

For every system, ``bench optimize --system optimize/data/systems/NAME.toml --wind-grid
GRID --no-stored-guess --out DIR/NAME`` runs in a scratch folder with no ``fit_out/``
(so the system's own ``[drive]`` is in force), unless ``--from DIR`` names a folder
that already holds ``NAME/summary.parquet`` and ``NAME.log`` of such a run. Prints,
as a Markdown table per system and wind speed: status, IPOPT iterations, P_mech,
P_elec, the electrical-to-mechanical ratio, whether P_elec is within the drive's own
efficiency of P_mech (``P_elec > P_mech``: generating returns less than the shaft
gives, motoring draws more than it delivers; the ratio at the same operating points
is what the carried loss model gives), and the active bounds. Then a copy of the
AP2 file without its ``scaling`` key: the exit code, the error line and its wall time.
Writes ``benchmarks/out/system_drives.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
BENCH = Path(sys.executable).parent / "bench"


def run_system(name: str, grid: str, out: Path) -> dict:
    """Run bench optimize for one shipped system in a folder with no fit_out/."""
    system = ROOT / "optimize" / "data" / "systems" / f"{name}.toml"
    with tempfile.TemporaryDirectory() as cwd:
        t0 = time.perf_counter()
        proc = subprocess.run([str(BENCH), "optimize", "--system", str(system), "--wind-grid",
                               grid, "--no-stored-guess", "--out", str(out / name)],
                              cwd=cwd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    (out / f"{name}.log").write_text(proc.stdout + proc.stderr + f"\nexit {proc.returncode}\n")
    return {"exit": proc.returncode, "wall_s": wall}


def drive_lines(log: Path) -> list[str]:
    """The lines ``bench optimize`` printed about the drive in force."""
    return [ln for ln in log.read_text().splitlines() if ln.startswith("drive ")]


def table(name: str, folder: Path) -> tuple[str, list[dict]]:
    """The Markdown table of one system's summary."""
    s = pd.read_parquet(folder / name / "summary.parquet").sort_values(
        ["kind", "wind_speed_m_s"])
    rows, lines = [], [
        "| system | scenario | status | it | P_mech [W] | P_elec [W] | P_elec/P_mech | "
        "within efficiency | active bounds |", "|---|---|---|---:|---:|---:|---:|---|---|"]
    for r in s.itertuples(index=False):
        ok = bool(r.success)
        within = ok and r.avg_p_elec_w > r.avg_p_mech_w
        ratio = r.avg_p_elec_w / r.avg_p_mech_w if ok and r.avg_p_mech_w else float("nan")
        rows.append({"system": name, "scenario": r.scenario, "status": r.status,
                     "iterations": int(r.iterations), "p_mech_w": float(r.avg_p_mech_w),
                     "p_elec_w": float(r.avg_p_elec_w), "within_efficiency": within,
                     "active_bounds": r.active_bounds})
        lines.append(f"| {name} | {r.scenario} | {r.status} | {r.iterations} | "
                     f"{r.avg_p_mech_w:.4g} | {r.avg_p_elec_w:.4g} | {ratio:.3f} | "
                     f"{'yes' if within else 'NO'} | {r.active_bounds or '-'} |")
    return "\n".join(lines), rows


def missing_scaling_key() -> dict:
    """AP2 without its scaling key: bench optimize must stop with exit 2 naming it."""
    text = (ROOT / "optimize/data/systems/ap2.toml").read_text()
    text = text.replace('scaling = "similarity"\n', "")
    with tempfile.TemporaryDirectory() as cwd:
        path = Path(cwd) / "ap2_no_scaling.toml"
        path.write_text(text)
        t0 = time.perf_counter()
        proc = subprocess.run([str(BENCH), "optimize", "--system", str(path), "--out",
                               str(Path(cwd) / "o")], cwd=cwd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    return {"exit": proc.returncode, "stderr": proc.stderr.strip(), "wall_s": wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--systems", default="ap2,megawes")
    ap.add_argument("--wind-grid", default="4:13:3")
    ap.add_argument("--from", dest="source", type=Path, default=None,
                    help="folder with NAME/summary.parquet and NAME.log of earlier runs")
    args = ap.parse_args()
    out = args.source or ROOT / "benchmarks" / "out" / "system_drives"
    out.mkdir(parents=True, exist_ok=True)
    record: dict = {"load_1min": os.getloadavg()[0], "systems": {}}
    for name in args.systems.split(","):
        run = {} if args.source else run_system(name, args.wind_grid, out)
        text, rows = table(name, out)
        lines = drive_lines(out / f"{name}.log")
        exit_line = [ln for ln in (out / f"{name}.log").read_text().splitlines()
                     if ln.startswith("exit ")]
        print(f"\n{name}: " + "; ".join(lines) + (f"; {exit_line[-1]}" if exit_line else ""))
        print(text)
        record["systems"][name] = {**run, "drive": lines, "rows": rows}
    check = missing_scaling_key()
    print(f"\nap2 without [drive] scaling: exit {check['exit']} in {check['wall_s']:.1f} s: "
          f"{check['stderr']}")
    record["missing_scaling_key"] = check
    (ROOT / "benchmarks" / "out").mkdir(exist_ok=True)
    (ROOT / "benchmarks" / "out" / "system_drives.json").write_text(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
