"""Inputs that a plausible-looking ingest used to get wrong, through ``bench ingest``.

Each class is written with a known truth (``bench.synth.exports``, ``tests/*fixtures.py``):

- ``aron_sum_of_3``: a two-wattmeter (3V3A) analyzer export whose p_elec is mapped as
  the sum of all three elements (the right total is P1 + P2);
- ``p_elec_is_omega_t``: a logger whose mapped p_elec column holds speed x torque;
- ``rad_s_under_rpm``: a DAQ writing speed in rad/s under a ``[1/min]`` header;
- ``noisy_hold_1hz``: a 1 Hz logger whose hold 3 scatters 12 x more than the rest;
- ``drift_37ppm_1hz``: DAQ and analyzer at 1 Hz, clocks drifting by +37 ppm;
- ``stamped_4hz_ampm``: whole-second 12-hour stamps (``11:59:59 AM``) at 4 rows per
  second, columns ``Date/Time`` and ``Power [W]`` without a mapping;
- ``analyzer_late_and_gap_1hz``: DAQ and analyzer at 1 Hz, 16 holds of 30 s; the
  analyzer's first 75 s and 50 s in the middle are missing (holds 0, 1 and 7 unrecorded);
- ``daq_gap_1hz``: the same 1 Hz pair, the analyzer complete, the DAQ missing 100 s
  (holds 6, 7 and 8 logged by the analyzer only);
- ``counter_4hz_dropped_rows``: whole-second stamps at 4 rows per second, every 7th
  row dropped, a ``Sample`` counter within each stamp mapped as ``sample_counter``
  (printed: the largest error of a stored sample time against the row's true time).

Each is ingested in a subprocess (so ``PYTHONPATH=<other checkout>`` compares two
versions on the same files); printed: the exit code, the error's first 160
characters, the points stored and what they show against the truth.

    .venv/bin/python benchmarks/ingest_honesty.py [--out DIR] [--campaigns DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]


def write_campaigns(folder: Path) -> dict:
    """Write every class into ``folder/<name>/``; return what the report needs of the truth."""
    sys.path.insert(0, str(ROOT / "tests"))
    from ingest_fixtures import make_timeseries_session
    from stream_fixtures import (
        cut_analyzer,
        cut_daq,
        make_counted_log,
        make_ev_export,
        make_german_logger,
    )
    from test_ingest_slow_logs import _write_stamped_log

    from bench.synth.exports import make_two_wattmeter_table

    truth: dict = {}
    t = make_two_wattmeter_table(folder / "aron_sum_of_3", channels=3)
    truth["aron_sum_of_3"] = {"p_elec_w": t["p_elec_w"].tolist()}
    make_ev_export(folder / "p_elec_is_omega_t", n_extra=20, with_p_mech=False)
    m = folder / "p_elec_is_omega_t" / "ev_01" / "mapping.toml"
    m.write_text(m.read_text().replace('"P_DC_total [kW]"', '"P_Mech [kW]"'))
    make_timeseries_session(folder / "rad_s_under_rpm", mode="motor", markers=False)
    daq = folder / "rad_s_under_rpm" / "motor_01" / "daq.csv"
    head, *rows = daq.read_text().splitlines()
    daq.write_text("\n".join([head] + [
        f"{r.split(',')[0]},{float(r.split(',')[1]) * 2 * math.pi / 60:.6f},{r.split(',')[2]}"
        for r in rows]) + "\n")
    g = make_german_logger(folder / "noisy_hold_1hz", noisy_hold=3)
    truth["noisy_hold_1hz"] = {"hold_s": [float(g.step_s[3]), float(g.step_s[3] + g.hold_s)]}
    sp = [(s, q) for s in (300.0, 600.0, 900.0, 1200.0) for q in (10.0, 30.0, 50.0, 70.0)]
    c = make_timeseries_session(folder / "drift_37ppm_1hz", setpoints=sp, hold_s=30.0,
                                daq_hz=1.0, analyzer_hz=1.0, drift_ppm=37.0, markers=False)
    truth["drift_37ppm_1hz"] = {"drift_ppm": c.drift_ppm, "offset_s": c.offset_s}
    _write_stamped_log(folder / "stamped_4hz_ampm", ampm=True)
    make_timeseries_session(folder / "analyzer_late_and_gap_1hz", setpoints=sp, hold_s=30.0,
                            daq_hz=1.0, analyzer_hz=1.0, drift_ppm=0.0, markers=False)
    cut_analyzer(folder / "analyzer_late_and_gap_1hz" / "motor_01" / "analyzer.csv",
                 [(0.0, 75.0), (200.0, 250.0)])
    make_timeseries_session(folder / "daq_gap_1hz", setpoints=sp, hold_s=30.0, daq_hz=1.0,
                            analyzer_hz=1.0, drift_ppm=0.0, markers=False)
    cut_daq(folder / "daq_gap_1hz" / "motor_01" / "daq.csv", [(190.0, 290.0)])
    t = make_counted_log(folder / "counter_4hz_dropped_rows", "stamp_plus_counter")
    truth["counter_4hz_dropped_rows"] = {"time_s": (t - t[0]).tolist()}
    (folder / "truth.json").write_text(json.dumps(truth))
    return truth


def run(name: str, campaign: Path, work: Path, truth: dict) -> dict:
    """Ingest one class in a subprocess; the row of the report."""
    store = work / name
    code = ("import sys; from drivebench.cli import main; "
            f"sys.exit(main(['ingest', {str(campaign)!r}, '--store', {str(store)!r}, "
            "'--no-progress']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    row = {"class": name, "exit": proc.returncode,
           "error": proc.stderr.strip().splitlines()[-1][:160] if proc.returncode else ""}
    if proc.returncode:
        return row
    man = json.loads((store / "manifest.json").read_text())
    gen = store / man["generation"]
    pts = pd.concat([pd.read_parquet(p) for p in (gen / "points").glob("*.parquet")])
    rej = pd.concat([pd.read_parquet(p) for p in (gen / "rejected").glob("*.parquet")])
    pm, pe = pts["p_mech_w"].to_numpy(), pts["p_elec_w"].to_numpy()
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(pm > 0, pm / pe, pe / pm)
    row.update({"points": len(pts), "rejected": dict(rej["reason"].value_counts()),
                "eta_min": float(np.nanmin(eta)), "eta_max": float(np.nanmax(eta))})
    if name == "aron_sum_of_3":
        true = np.asarray(truth[name]["p_elec_w"])[pts.sort_values("point_id")["point_id"]]
        ratio = pts.sort_values("point_id")["p_elec_w"].to_numpy() / true
        row["p_elec_over_truth"] = [float(ratio.min()), float(ratio.max())]
    if name == "p_elec_is_omega_t":
        row["points_eta_1_within_1e-3"] = int((np.abs(eta - 1) < 1e-3).sum())
    if name == "noisy_hold_1hz":
        a, b = truth[name]["hold_s"]
        inside = rej[(rej["t_end_s"] > a) & (rej["t_start_s"] < b)]
        row["hold_windows"] = inside[["t_start_s", "t_end_s", "reason"]].values.tolist()
    if name == "counter_4hz_dropped_rows":
        got = np.sort(pd.read_parquet(next((gen / "samples").glob("*.parquet")))["time_s"])
        true = np.asarray(truth[name]["time_s"])
        row["max_time_error_s"] = (float(np.max(np.abs(got - true))) if got.size == true.size
                                   else f"{got.size} samples stored of {true.size}")
    e = next(iter(man["sessions"].values()))
    for key in ("clock_drift_ppm", "clock_drift_estimate_ppm", "clock_drift_uncertainty_ppm",
                "clock_offset_s"):
        if name.startswith("drift") and key in e:
            row[key] = e[key]
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="work folder (default: a temporary one)")
    parser.add_argument("--campaigns", type=Path, help="campaigns written by an earlier run")
    args = parser.parse_args()
    work = args.out or Path(tempfile.mkdtemp(prefix="ingest_honesty_"))
    campaigns = args.campaigns or work / "campaigns"
    truth = (json.loads((campaigns / "truth.json").read_text()) if args.campaigns
             else write_campaigns(campaigns))
    for c in sorted(p for p in campaigns.iterdir() if p.is_dir()):
        print(json.dumps(run(c.name, c, work / "stores", truth), default=str))
    print(f"campaigns: {campaigns}\nwork folder: {work}")


if __name__ == "__main__":
    main()
