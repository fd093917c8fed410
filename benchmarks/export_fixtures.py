"""Foreign exports with a known truth through the mapping, ingest and fit: points, peak eta.

Each class is written by ``bench.synth.exports`` (a dyno table in N mm with a
title and a date line; an EV bench's 500-column export with p_elec mapped as
``{U_DC [V]} * {I_DC [A]}`` or as the sum of three wattmeters), then
``bench ingest`` and ``bench fit --order 2``. Printed per class and quadrant:
the points ingest stored against the rows written, the largest error of the
stored p_elec against the truth, the map's peak efficiency, the truth's peak over
the nodes the map shows, and the measured maximum.

    .venv/bin/python benchmarks/export_fixtures.py [--out DIR]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest.pipeline import ingest
from bench.store.read import read_points
from bench.synth.exports import make_dyno_table, make_ev_table, true_eta
from fitting.pipeline import FitOptions, run_fit

#: name -> writer(root) -> truth
CLASSES = {
    "dyno table, N mm, 2 title lines": lambda root: make_dyno_table(root),
    "EV export, 500 columns, expr U*I": lambda root: make_ev_table(root, p_elec_by="expr"),
    "EV export, 500 columns, sum of 3": lambda root: make_ev_table(root, p_elec_by="sum"),
}


def run_class(name: str, write, work: Path) -> list[dict]:
    """Write -> ingest -> fit one class; one row per quadrant."""
    folder = work / name.split(",")[0].replace(" ", "_") / name.split(", ")[-1].replace(" ", "_")
    truth = write(folder / "campaign")
    ingest([folder / "campaign"], folder / "store", progress=False)
    summary = run_fit(folder / "store", folder / "fit", FitOptions(), progress=False)
    stored = read_points(folder / "store").sort_values("point_id")
    emap = pd.read_parquet(folder / "fit" / "efficiency_map.parquet")
    written_q = np.where(truth["speed_rpm"] * truth["torque_nm"] > 0, "motor", "generator")
    rows = []
    for q in ("motor", "generator"):
        shown = emap[(emap["quadrant"] == q) & emap["status"].isin(("ok", "clipped"))]
        eta = true_eta(shown["speed_rpm"].to_numpy(), shown["torque_nm"].to_numpy(),
                       truth["loss"])
        peak = summary["efficiency"]["peak"].get(q) or {}
        mine = stored["quadrant"] == q
        err = np.abs(stored["p_elec_w"].to_numpy()[mine]
                     - truth["p_elec_w"][written_q == q]) if mine.sum() == (written_q == q).sum() \
            else np.array([np.nan])
        rows.append({
            "class": name, "quadrant": q,
            "points_written": int((written_q == q).sum()),
            "points_stored": int(mine.sum()),
            "max_p_elec_err_w": float(err.max()),
            "map_peak_eta": (peak.get("map") or {}).get("eta"),
            "truth_peak_eta_shown": float(np.nanmax(eta)) if eta.size else None,
            "measured_max_eta": (peak.get("measured") or {}).get("eta"),
        })
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="work folder (default: a temporary one)")
    args = parser.parse_args()
    work = args.out or Path(tempfile.mkdtemp(prefix="export_fixtures_"))
    rows = [r for name, write in CLASSES.items() for r in run_class(name, write, work)]
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 200, "display.max_columns", 20,
                           "display.float_format", "{:.4f}".format):
        print(table.to_string(index=False))
    print(f"work folder: {work}")


if __name__ == "__main__":
    main()
