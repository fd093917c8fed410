"""Fixture classes with a known truth through ingest and fit: points per quadrant, peak eta.

Each class is a campaign of operating-point tables written by
``bench.synth.rated_drive`` (a power-limited drive: full torque to base speed,
constant power above) with its ``drive.toml``, then ``bench ingest`` and
``bench fit --order 2``. Printed per class and quadrant: the points ingest
recovered (against the points written), the map's peak efficiency, the truth's
peak over the same measured region, the measured maximum (of all accepted points,
which sets the ceiling), the map's ceiling (that maximum plus its uncertainty), and
the map nodes drawn above the true torque envelope.

    .venv/bin/python benchmarks/fit_fixtures.py [--out DIR]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest.pipeline import ingest
from bench.store.read import read_points
from bench.synth.rated_drive import EV_DRIVE, PAPER_DRIVE, grid_points, write_table_campaign
from fitting.pipeline import FitOptions, run_fit

#: name -> (drive, quadrants, P_elec noise [W])
CLASSES = {
    "motor only (8.2 kW, 1500 rpm)": (PAPER_DRIVE, ("motor",), 40.0),
    "generator only (8.2 kW, 1500 rpm)": (PAPER_DRIVE, ("generator",), 40.0),
    "150 kW, 12000 rpm, non-convex envelope": (EV_DRIVE, ("motor", "generator"), 300.0),
}


def run_class(name: str, drive, quadrants, noise_w: float, work: Path) -> list[dict]:
    """Synth -> ingest -> fit one class; one row per quadrant."""
    folder = work / name.split(" (")[0].replace(" ", "_").replace(",", "")
    pts = grid_points(drive, quadrants, noise_w=noise_w, seed=7)
    write_table_campaign(folder / "campaign", drive, pts)
    ingest([folder / "campaign"], folder / "store", progress=False)
    summary = run_fit(folder / "store", folder / "fit", FitOptions(), progress=False)
    stored = read_points(folder / "store")
    emap = pd.read_parquet(folder / "fit" / "efficiency_map.parquet")
    rows = []
    for q in quadrants:
        shown = emap[(emap["quadrant"] == q) & emap["status"].isin(("ok", "clipped"))]
        truth_eta = drive.eta(shown["speed_rpm"], shown["torque_nm"])
        above = shown["torque_nm"] > drive.rating.largest_torque_nm(shown["speed_rpm"]) + 1e-9
        peak = summary["efficiency"]["peak"][q]
        rows.append({
            "class": name, "quadrant": q,
            "points_written": int((pts["quadrant"] == q).sum()),
            "points_stored": int((stored["quadrant"] == q).sum()),
            "map_peak_eta": peak["map"]["eta"],
            "truth_peak_eta": float(np.nanmax(truth_eta)),
            "measured_max_eta": peak["measured"]["eta"],
            "ceiling_eta": peak["ceiling"]["eta"],
            "nodes_above_true_envelope": int(above.sum()),
            "nodes_shown": len(shown),
        })
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="work folder (default: a temporary one)")
    args = parser.parse_args()
    work = args.out or Path(tempfile.mkdtemp(prefix="fit_fixtures_"))
    rows = [r for name, (d, qs, noise) in CLASSES.items()
            for r in run_class(name, d, qs, noise, work)]
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 200, "display.max_columns", 20,
                           "display.float_format", "{:.4f}".format):
        print(table.to_string(index=False))
    print(f"work folder: {work}")


if __name__ == "__main__":
    main()
