"""Benchmark ``bench ingest`` against the bare pandas baseline.

Generates (or reuses) a ``bench synth --scale N`` campaign, then measures, each in
its own child process, wall time and peak RSS of

* **ingest**: the whole ``bench ingest`` pipeline into a fresh store (read, scrub,
  align, steady windows, points, samples Parquet, manifest), and
* **floor**: the least work an ingest keeping the store contract must do: hash
  every source file, parse every DAQ and analyzer file with ingest's readers and
  write the samples Parquet, two sessions at a time; no checks, no alignment, no
  averaging. Its rows/s bounds what any speed-up of the rest can reach, and
* **baseline**: what a user writes by hand: ``pandas.read_csv`` of every CSV file
  (with the right separator, decimal mark and header rows, invalid markers as NaN)
  followed by ``DataFrame.to_parquet``; no alignment, no averaging. The TDMS
  session is not CSV, so the baseline skips it and its rows are not counted there.

rows/s = data rows read (DAQ + analyzer + point tables) / child wall time, best of
``--repeat`` alternating runs (the machine may be shared; the median and the rows
per CPU-second, user + system, are reported too). Peak RSS is the child's
``ru_maxrss`` from ``os.wait4``. Results: a table on stdout and
``benchmarks/out/ingest_benchmark.json``.

Usage::

    .venv/bin/python benchmarks/ingest_benchmark.py [--scale 55] [--campaign DIR] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "out"
GOAL_SPEEDUP = 3.0
GOAL_RSS_MIB = 1024.0

INGEST_CHILD = """
import sys
from bench.ingest.pipeline import ingest
r = ingest([sys.argv[1]], sys.argv[2], progress=False, workers=int(sys.argv[3]))
assert len(r.ingested) > 0
"""

#: The least work any ingest that keeps the store contract must do: hash every
#: source file, parse every DAQ and analyzer file with the readers ingest uses,
#: and write the samples Parquet (same schema and codec), two sessions at a time.
#: No checks, no clock alignment (p_elec left NaN), no steady windows, no points.
FLOOR_CHILD = """
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from kernel.files import file_sha256
from bench.ingest.mapping import EMPTY_MAPPING
from bench.ingest.csv_stream import CHUNK_BYTES
from bench.ingest.readers import read_analyzer
from bench.ingest.session import discover, load_session
from bench.ingest.samples_file import SAMPLES_WRITE_OPTIONS
from bench.ingest.timeseries import open_stream
from bench.store.schema import SAMPLES_SCHEMA
from kernel.units import RPM_PER_RAD_S
from bench.store.schema import SAMPLES_SCHEMA, TEMPERATURE_COLUMNS
camp, out = Path(sys.argv[1]), Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
def one(folder):
    s = load_session(folder)
    for f in sorted(folder.iterdir()):
        file_sha256(f)
    if s.kind != "timeseries":
        return
    read_analyzer(s.file("analyzer"))
    sid = pa.array([s.session_id], pa.string())
    with pq.ParquetWriter(out / f"{s.session_id}.parquet", SAMPLES_SCHEMA,
                          **SAMPLES_WRITE_OPTIONS) as w:
        for c in open_stream(s, EMPTY_MAPPING, CHUNK_BYTES).chunks():
            t, n, q = c.values["time"], c.values["speed"], c.values["torque"]
            w.write_table(pa.Table.from_arrays([
                pa.DictionaryArray.from_arrays(np.zeros(t.size, np.int32), sid), t, n, q,
                n * q / RPM_PER_RAD_S, np.full(t.size, np.nan), np.full(t.size, -1, np.int32),
                *(np.full(t.size, np.nan) for _ in TEMPERATURE_COLUMNS),
            ], schema=SAMPLES_SCHEMA))
with ThreadPoolExecutor(int(sys.argv[3])) as ex:
    list(ex.map(one, discover([camp])))
"""

BASELINE_CHILD = r"""
import sys
from pathlib import Path
import pandas as pd
MARKERS = ["NAN", "NaN", "-INF", "INF", "---", "9.91E+37", "9.9E37"]
camp, out = Path(sys.argv[1]), Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
for path in sorted(camp.rglob("*.csv")):
    with path.open("rb") as fh:
        head = fh.read(4096).decode("utf-8", "replace").splitlines()
    skip = head.index("") + 1 if "" in head[:20] else 0   # analyzer header block
    german = ";" in head[skip]
    units_row = [skip + 1] if german else []
    df = pd.read_csv(path, sep=";" if german else ",", decimal="," if german else ".",
                     skiprows=list(range(skip)) + units_row, na_values=MARKERS)
    df.columns = [str(c) for c in df.columns]
    df.to_parquet(out / (path.parent.name + "_" + path.stem + ".parquet"))
"""


def run_child(code: str, *args: str) -> dict:
    """Run ``python -c code args`` and return its wall time [s] and peak RSS [MiB]."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", code, *args], cwd=ROOT)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"child failed with exit code {proc.returncode}")
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime,
            "peak_rss_mib": usage.ru_maxrss / 1024.0}  # Linux: KiB


def count_rows(campaign: Path) -> dict:
    """Data rows per kind of file, from the campaign's truth.json and its files."""
    truth = json.loads((campaign / "truth.json").read_text())
    daq = daq_csv = analyzer = table = 0
    for sid, s in truth["sessions"].items():
        if s["kind"] == "timeseries":
            daq += s["daq_rows"]
            analyzer += s["analyzer_rows"]
            if (campaign / sid / "daq.csv").exists():
                daq_csv += s["daq_rows"]
        else:
            table += s["n_points"]
    return {"daq": daq, "daq_csv": daq_csv, "analyzer": analyzer, "table": table}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=int, default=55,
                    help="bench synth --scale (55 gives >= 20 million DAQ rows)")
    ap.add_argument("--campaign", type=Path, default=None,
                    help="reuse (or create here) the campaign instead of a temp dir")
    ap.add_argument("--workers", type=int, default=2, help="bench ingest --workers (default 2)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="alternating runs of each; the best wall time counts (default 3)")
    ap.add_argument("--keep", action="store_true", help="keep the temp campaign and outputs")
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="ingest_bench_"))
    campaign = args.campaign or work / "campaign"
    try:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "drivebench.cli", "synth", str(campaign),
                        "--scale", str(args.scale), "--check"], check=True, cwd=ROOT)
        synth_s = time.perf_counter() - t0
        rows = count_rows(campaign)
        size = sum(p.stat().st_size for p in campaign.rglob("*") if p.is_file())
        print(f"campaign {campaign}: scale {args.scale}, {rows['daq']:,} DAQ rows "
              f"({rows['daq_csv']:,} in CSV), {rows['analyzer']:,} analyzer rows, "
              f"{size / 2**20:.0f} MiB (synth/check {synth_s:.0f} s)")

        # alternate the two, several times: other work on the machine shifts wall times
        runs: dict[str, list[dict]] = {"ingest": [], "floor": [], "baseline": []}
        for k in range(args.repeat):
            store = work / f"store{k}"
            runs["ingest"].append(run_child(INGEST_CHILD, str(campaign), str(store),
                                            str(args.workers)))
            runs["floor"].append(run_child(FLOOR_CHILD, str(campaign), str(work / f"floor{k}"),
                                           str(args.workers)))
            runs["baseline"].append(run_child(BASELINE_CHILD, str(campaign),
                                              str(work / f"baseline{k}")))
            for d in (store, work / f"floor{k}", work / f"baseline{k}"):
                shutil.rmtree(d, ignore_errors=True)
            print(f"run {k + 1}/{args.repeat}: ingest {runs['ingest'][-1]['wall_s']:.1f} s, "
                  f"floor {runs['floor'][-1]['wall_s']:.1f} s, "
                  f"baseline {runs['baseline'][-1]['wall_s']:.1f} s", flush=True)
        n_rows = {"ingest": rows["daq"] + rows["analyzer"] + rows["table"],
                  "floor": rows["daq"] + rows["analyzer"] + rows["table"],
                  "baseline": rows["daq_csv"] + rows["analyzer"] + rows["table"]}
        summary = {}
        for name, rs in runs.items():
            walls = sorted(r["wall_s"] for r in rs)
            best = walls[0]
            summary[name] = {
                "rows": n_rows[name], "wall_s_best": best, "wall_s_median": walls[len(walls) // 2],
                "rows_per_s": n_rows[name] / best,
                "rows_per_s_median": n_rows[name] / walls[len(walls) // 2],
                "rows_per_cpu_s": n_rows[name] / min(r["cpu_s"] for r in rs),
                "peak_rss_mib": max(r["peak_rss_mib"] for r in rs), "runs": rs,
            }
        ing, floor, base = summary["ingest"], summary["floor"], summary["baseline"]
        speedup = ing["rows_per_s"] / base["rows_per_s"]
        floor_speedup = floor["rows_per_s"] / base["rows_per_s"]
        result = {
            "scale": args.scale, "workers": args.workers, "campaign_bytes": size, "rows": rows,
            "ingest": ing, "floor": floor, "baseline": base, "speedup": speedup,
            "floor_speedup": floor_speedup,
            "speedup_median": ing["rows_per_s_median"] / base["rows_per_s_median"],
            "speedup_cpu": ing["rows_per_cpu_s"] / base["rows_per_cpu_s"],
            "goal": {"speedup": GOAL_SPEEDUP, "peak_rss_mib": GOAL_RSS_MIB,
                     "speedup_met": speedup >= GOAL_SPEEDUP,
                     "rss_met": ing["peak_rss_mib"] <= GOAL_RSS_MIB},
            "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                        "load_avg_1min_at_end": os.getloadavg()[0]},
        }
        print(f"\n{'':10s} {'rows':>12s} {'best [s]':>9s} {'median [s]':>10s} {'rows/s':>12s} "
              f"{'rows/CPU-s':>11s} {'peak RSS [MiB]':>15s}")
        for name, r in summary.items():
            print(f"{name:10s} {r['rows']:>12,} {r['wall_s_best']:>9.1f} "
                  f"{r['wall_s_median']:>10.1f} {r['rows_per_s']:>12,.0f} "
                  f"{r['rows_per_cpu_s']:>11,.0f} {r['peak_rss_mib']:>15.0f}")
        print(f"\nspeed-up (best wall) {speedup:.2f}x, median {result['speedup_median']:.2f}x, "
              f"CPU {result['speedup_cpu']:.2f}x (goal >= {GOAL_SPEEDUP:.0f}x: "
              f"{'met' if result['goal']['speedup_met'] else 'NOT met'}); ingest peak RSS "
              f"{ing['peak_rss_mib']:.0f} MiB (goal <= {GOAL_RSS_MIB:.0f}: "
              f"{'met' if result['goal']['rss_met'] else 'NOT met'}); "
              f"load average {result['machine']['load_avg_1min_at_end']:.1f} "
              f"on {os.cpu_count()} CPUs")
        print(f"floor (hash + parse + samples write only) {floor_speedup:.2f}x the baseline, "
              f"CPU {floor['rows_per_cpu_s'] / base['rows_per_cpu_s']:.2f}x")
        OUT.mkdir(parents=True, exist_ok=True)
        out = OUT / "ingest_benchmark.json"
        tmp = out.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(result, indent=1) + "\n")
        os.replace(tmp, out)
        print(f"results: {out}")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
        else:
            print(f"kept {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
