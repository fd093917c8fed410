"""Points ``bench ingest`` finds when a session's DAQ is logged slower (issue 10 finding 1).

Copies one timeseries session (default ``raw_measurements/motor_01``), keeps
every k-th DAQ row so that the DAQ runs at each requested rate (the analyzer
record is unchanged), ingests each copy into a fresh store and prints the
points per quadrant, the rejected windows and, for 0 points, the summary's
reason. The full-rate session is the reference.

Usage::

    .venv/bin/python benchmarks/low_rate_ingest.py [--session raw_measurements/motor_01]
        [--rates 5,1,0.5]
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np

from bench.ingest.pipeline import ingest

ROOT = Path(__file__).resolve().parents[1]


def decimate(src: Path, dst: Path, rate_hz: float | None) -> float:
    """Copy session ``src`` to ``dst`` with its DAQ CSV thinned to ``rate_hz`` (None: as is);
    return the DAQ rate of the copy [Hz]."""
    shutil.copytree(src, dst)
    daq = dst / "daq.csv"
    lines = daq.read_text().splitlines()
    head, rows = lines[:1], lines[1:]
    t = np.array([float(r.split(",")[0]) for r in rows[:1000]])
    native = 1.0 / float(np.median(np.diff(t)))
    if rate_hz is None:
        return native
    step = max(1, int(round(native / rate_hz)))
    daq.write_text("\n".join(head + rows[::step]) + "\n")
    return native / step


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--session", type=Path, default=ROOT / "raw_measurements" / "motor_01")
    ap.add_argument("--rates", default="5,1,0.5", help="DAQ rates to try [Hz], comma separated")
    args = ap.parse_args()
    rates = [None] + [float(r) for r in args.rates.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for rate in rates:
            case = Path(tmp) / f"r{rate}"
            hz = decimate(args.session, case / args.session.name, rate)
            res = ingest([case], case / "store", progress=False)
            e = res.manifest["sessions"][args.session.name]
            rows.append({
                "daq_hz": round(hz, 3), "points": e["n_points"],
                "motor": e["points_per_quadrant"]["motor"],
                "generator": e["points_per_quadrant"]["generator"],
                "rejected": e["rejected"], "bin_s": e["timing"]["bin_s"],
                "note": e.get("no_points_note", ""),
            })
    print(f"session {args.session}")
    print(f"{'DAQ [Hz]':>9} {'points':>7} {'motor':>6} {'gen':>5} {'bin [s]':>8}  rejected")
    for r in rows:
        print(f"{r['daq_hz']:>9g} {r['points']:>7} {r['motor']:>6} {r['generator']:>5} "
              f"{r['bin_s']:>8g}  {json.dumps(r['rejected'])} {r['note']}")


if __name__ == "__main__":
    main()
