"""A kite of your own (issue 40): the paper's system as a new user would change it, a
30 kg glider with a 5 m/s^2 reel-acceleration limit, swept in all four kinds.

Usage::

    .venv/bin/python benchmarks/own_kite.py [--wind-grid 4:14:2] [--intervals 14 --degree 3]
        [--out benchmarks/out/own_kite]

Writes ``glider30.toml`` (``highwind.toml`` with ``[kite] mass_kg = 30`` and ``[winch]
max_reel_acceleration_m_s2 = 5``) into ``--out``, runs ``bench optimize --system
glider30.toml --no-claims`` there on the given mesh (default: the default mesh), and
prints one row per scenario: status, the mesh its result stands on (``n_intervals``; a
finer one than the sweep's when the last retry refined it), its start and its average
mechanical power. Figures in benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
BENCH = Path(sys.executable).parent / "bench"
HIGHWIND = ROOT / "optimize" / "data" / "systems" / "highwind.toml"


def glider_text() -> str:
    """``highwind.toml`` with a 30 kg kite and a 5 m/s^2 reel-acceleration limit."""
    text = HIGHWIND.read_text()
    data = tomllib.loads(text)
    old_mass = f"mass_kg = {data['kite']['mass_kg']}"
    assert old_mass in text and "max_reel_acceleration_m_s2" not in text
    text = text.replace(old_mass, "mass_kg = 30.0", 1).replace('name = "highwind"',
                                                               'name = "glider30"', 1)
    return text.replace("[winch]\n", "[winch]\nmax_reel_acceleration_m_s2 = 5.0\n", 1)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wind-grid", default="4:14:2")
    ap.add_argument("--intervals", type=int)
    ap.add_argument("--degree", type=int)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "own_kite")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "glider30.toml").write_text(glider_text())
    mesh = [f"--{k}={v}" for k, v in (("intervals", args.intervals), ("degree", args.degree))
            if v is not None]
    folder = args.out / "optimize"
    t0 = time.perf_counter()
    done = subprocess.run([str(BENCH), "optimize", "--system", str(args.out / "glider30.toml"),
                           "--wind-grid", args.wind_grid, "--no-claims", "--no-progress",
                           *mesh, "--out", str(folder)], capture_output=True, text=True)
    print(f"exit {done.returncode}, {time.perf_counter() - t0:.0f} s")
    s = pd.read_parquet(folder / "summary.parquet")
    print("| scenario | status | passed | mesh intervals | start | P_mech [W] |\n"
          "|---|---|---|---:|---|---:|")
    for r in s.itertuples(index=False):
        print(f"| {r.scenario} | {r.status} | {'yes' if r.success else 'no'} | "
              f"{r.n_intervals} | {r.warm_source} | {r.avg_p_mech_w:.1f} |")
    return done.returncode


if __name__ == "__main__":
    sys.exit(main())
