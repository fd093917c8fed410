"""Points ``bench ingest`` recovers from the issue-10 timeseries fixtures, against their truth.

Writes each fixture of ``tests/stream_fixtures.py`` and ``tests/ingest_fixtures.py``
(the tests' own, with a known truth) into a temporary folder, ingests it, matches
every point to the hold its window lies in and prints, per quadrant, the points
found against the holds in the truth and the largest and mean errors of the
point means (speed, torque, p_elec).

Usage::

    .venv/bin/python benchmarks/ingest_fixture_recovery.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from ingest_fixtures import make_timeseries_session, paper_p_elec  # noqa: E402
from stream_fixtures import make_ev_export, make_german_logger  # noqa: E402

from bench.ingest.pipeline import ingest  # noqa: E402
from bench.store.read import read_points  # noqa: E402


def daq_case(daq_hz: float, hold_s: float):
    def make(root: Path):
        truth = make_timeseries_session(root, daq_hz=daq_hz, hold_s=hold_s, markers=False)
        speed = np.array([s for s, _ in truth.setpoints])
        torque = np.array([q for _, q in truth.setpoints])
        return (np.asarray(truth.step_times_s), speed, torque, paper_p_elec(speed, torque), 0)
    return make


def stream_case(maker):
    def make(root: Path):
        t = maker(root)
        return t.step_s, t.speed_rpm, t.torque_nm, t.p_elec_w, len(t.split_holds)
    return make


CASES = {
    "DAQ 1 Hz + analyzer (20 s holds)": daq_case(1.0, 20.0),
    "DAQ 5 Hz + analyzer (8 s holds)": daq_case(5.0, 8.0),
    "DAQ 10 kHz + analyzer (5 s holds)": daq_case(10_000.0, 5.0),
    "EV single-stream export (306 columns, signed torque, ms)": stream_case(make_ev_export),
    "German 1 Hz time-of-day logger (gaps, midnight)": stream_case(make_german_logger),
}


def main() -> None:
    for name, make in CASES.items():
        with tempfile.TemporaryDirectory() as tmp:
            step, speed, torque, p_elec, n_split = make(Path(tmp) / "c")
            ingest([Path(tmp) / "c"], Path(tmp) / "store", progress=False)
            pts = read_points(Path(tmp) / "store")
        mid = 0.5 * (pts.t_start_s.to_numpy() + pts.t_end_s.to_numpy())
        k = np.searchsorted(step, mid, side="right") - 1
        quad = np.where(speed * torque > 0, "motor", "generator")
        print(f"{name}: {len(pts)} points for {speed.size} holds"
              + (f" ({n_split} split by a gap)" if n_split else ""))
        for q in ("motor", "generator"):
            m = pts.quadrant.to_numpy() == q
            holds = int((quad == q).sum())
            if not m.any():
                print(f"  {q:9s}: 0 points, {holds} holds")
                continue
            err = {"speed [rpm]": pts.speed_rpm.to_numpy()[m] - speed[k[m]],
                   "torque [N m]": pts.torque_nm.to_numpy()[m] - torque[k[m]],
                   "p_elec [W]": pts.p_elec_w.to_numpy()[m] - p_elec[k[m]]}
            text = ", ".join(f"{e} max {np.max(np.abs(v)):.3g} mean {np.mean(v):+.3g}"
                             for e, v in err.items())
            print(f"  {q:9s}: {int(m.sum())} points, {holds} holds; error {text}")


if __name__ == "__main__":
    main()
