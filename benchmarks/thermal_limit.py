"""The paper sweep with and without the drive's thermal limit in the cycle.

Runs ``bench optimize`` twice on the same grid and drive model (one with a thermal block,
from ``bench fit`` of a campaign that logs the winding temperature): on the shipped
system as it is, and on a copy whose ``[drive]`` states ``max_winding_temperature_c``.
Prints per scenario the electrical power of both, the winding temperature of the cycle
(its cyclic steady state) and the active bounds, and the wall time of each sweep::

    .venv/bin/python benchmarks/thermal_limit.py --drive-model demo_out/fit/power_model.json \\
        --limit 50 --out /tmp/thermal_limit
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optimize.system.system import shipped_system_path  # noqa: E402


def limited_system(limit_c: float, out: Path) -> Path:
    """A copy of the shipped system with the winding limit in ``[drive]``."""
    text = shipped_system_path().read_text(encoding="utf-8")
    path = out / f"highwind_winding_{limit_c:g}c.toml"
    path.write_text(text.replace("[drive]\n", f"[drive]\nmax_winding_temperature_c = "
                                 f"{limit_c}\n", 1), encoding="utf-8")
    return path


def sweep(system: Path, model: Path, grid: str, out: Path) -> float:
    """Run one sweep into ``out``; its wall time [s]."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "drivebench.cli", "optimize", "--system", str(system),
                    "--drive-model", str(model), "--wind-grid", grid, "--no-claims",
                    "--out", str(out)], check=False, cwd=ROOT)
    return time.perf_counter() - t0


def table(plain: Path, hot: Path) -> pd.DataFrame:
    """Per scenario: P_elec without and with the limit, the temperature, the bounds."""
    a = pd.read_parquet(plain / "summary.parquet").set_index("scenario")
    b = pd.read_parquet(hot / "summary.parquet").set_index("scenario")
    return pd.DataFrame({
        "P_elec W (no limit)": a["avg_p_elec_w"], "P_elec W (limit)": b["avg_p_elec_w"],
        "diff W": b["avg_p_elec_w"] - a["avg_p_elec_w"],
        "theta max C": b["peak_winding_temperature_c"], "margin K": b["thermal_margin_k"],
        "status": b["status"], "active (limit)": b["active_bounds"]})


def main() -> None:
    """Run both sweeps and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drive-model", type=Path, required=True)
    ap.add_argument("--limit", type=float, default=50.0, help="winding limit [degC]")
    ap.add_argument("--wind-grid", default="4:10:1.5")
    ap.add_argument("--out", type=Path, default=Path("/tmp/thermal_limit"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    t_plain = sweep(shipped_system_path(), args.drive_model, args.wind_grid,
                    args.out / "plain")
    t_hot = sweep(limited_system(args.limit, args.out), args.drive_model, args.wind_grid,
                  args.out / "limited")
    print(table(args.out / "plain", args.out / "limited").to_string(float_format="%.2f"))
    print(f"wall time: {t_plain:.0f} s without, {t_hot:.0f} s with the winding limit "
          f"{args.limit:g} degC")


if __name__ == "__main__":
    main()
