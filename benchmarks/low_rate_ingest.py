"""Points ``bench ingest`` finds when a session's DAQ is logged slower or faster.

Copies one timeseries session (default ``raw_measurements/motor_01``), keeps
every k-th DAQ row so that the DAQ runs at each requested rate (the analyzer
record is unchanged), ingests each copy into a fresh store and prints the
points per quadrant, the rejected windows and, for 0 points, the summary's
reason. The full-rate session is the reference.

``--high-hz`` adds a fast case: the session's first ``--high-s`` seconds
interpolated onto a ``--high-hz`` grid (with the logged noise level added
again), ingested in a child process whose wall time and peak RSS are printed
next to those of the same span at the native rate.

Usage::

    .venv/bin/python benchmarks/low_rate_ingest.py [--session raw_measurements/motor_01]
        [--rates 5,1,0.5] [--high-hz 10000 --high-s 120]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
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


def resample(src: Path, dst: Path, rate_hz: float, span_s: float) -> int:
    """Copy ``src`` to ``dst`` with the DAQ's first ``span_s`` seconds on a ``rate_hz`` grid
    (linear interpolation plus white noise of the logged increments' level); rows written."""
    shutil.copytree(src, dst)
    daq = dst / "daq.csv"
    head = daq.read_text().splitlines()[0]
    x = np.genfromtxt(src / "daq.csv", delimiter=",", skip_header=1, max_rows=200_000)
    x = x[np.all(np.isfinite(x) & (np.abs(x) < 1e30), axis=1) & (x[:, 0] <= span_s)]
    t = np.arange(x[0, 0], x[-1, 0], 1.0 / rate_hz)
    rng = np.random.default_rng(0)
    cols = [t]
    for j in (1, 2):
        sigma = 1.4826 * np.median(np.abs(np.diff(x[:, j]))) / np.sqrt(2)
        cols.append(np.interp(t, x[:, 0], x[:, j]) + rng.normal(0, sigma, t.size))
    np.savetxt(daq, np.column_stack(cols), fmt=["%.5f", "%.3f", "%.4f"], delimiter=",",
               header=head, comments="")
    return t.size


CHILD = """
import resource, sys, time
from bench.ingest.pipeline import ingest
t0 = time.perf_counter()
r = ingest([sys.argv[1]], sys.argv[2], progress=False)
e = r.manifest["sessions"][sys.argv[3]]
print(time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
      e["n_points"])
"""


def timed_ingest(case: Path, sid: str) -> tuple[float, float, int]:
    """Wall time [s], peak RSS [MiB] and points of one ingest in a child process."""
    out = subprocess.run([sys.executable, "-c", CHILD, str(case), str(case / "store"), sid],
                         check=True, capture_output=True, text=True, cwd=ROOT,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}).stdout.split()
    return float(out[0]), float(out[1]), int(out[2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--session", type=Path, default=ROOT / "raw_measurements" / "motor_01")
    ap.add_argument("--rates", default="5,1,0.5", help="DAQ rates to try [Hz], comma separated")
    ap.add_argument("--high-hz", type=float, default=0.0, help="fast case: DAQ rate [Hz]")
    ap.add_argument("--high-s", type=float, default=120.0, help="fast case: seconds of the session")
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
        if args.high_hz:
            fast = []
            for hz in (None, args.high_hz):
                case = Path(tmp) / f"h{hz}"
                if hz is None:  # the same span at the native rate
                    n = _head(args.session, case / args.session.name, args.high_s)
                else:
                    n = resample(args.session, case / args.session.name, hz, args.high_s)
                t0 = time.perf_counter()
                wall, rss, pts = timed_ingest(case, args.session.name)
                fast.append((hz, n, wall, rss, pts, time.perf_counter() - t0))
    print(f"session {args.session}")
    print(f"{'DAQ [Hz]':>9} {'points':>7} {'motor':>6} {'gen':>5} {'bin [s]':>8}  rejected")
    for r in rows:
        print(f"{r['daq_hz']:>9g} {r['points']:>7} {r['motor']:>6} {r['generator']:>5} "
              f"{r['bin_s']:>8g}  {json.dumps(r['rejected'])} {r['note']}")
    if args.high_hz:
        print(f"first {args.high_s:g} s of the session, ingest in a child process:")
        print(f"{'DAQ [Hz]':>9} {'rows':>10} {'points':>7} {'wall [s]':>9} {'peak RSS [MiB]':>15}")
        for hz, n, wall, rss, pts, _ in fast:
            print(f"{'native' if hz is None else f'{hz:g}':>9} {n:>10,} {pts:>7} {wall:>9.2f} "
                  f"{rss:>15.0f}")


def _head(src: Path, dst: Path, span_s: float) -> int:
    """Copy ``src`` to ``dst`` with the DAQ's first ``span_s`` seconds only; rows kept."""
    shutil.copytree(src, dst)
    lines = (src / "daq.csv").read_text().splitlines()
    keep = [ln for ln in lines[1:] if float(ln.split(",")[0]) <= span_s]
    (dst / "daq.csv").write_text("\n".join(lines[:1] + keep) + "\n")
    return len(keep)


if __name__ == "__main__":
    main()
