"""Benchmark: ``bench ingest`` + ``bench fit`` on the shipped campaign, against its truth.

Usage::

    .venv/bin/python benchmarks/fit_recovery.py [raw_measurements] [--out DIR]

Ingests the campaign into DIR/bench_store, runs the full fit (with selection)
for each quadrant weighting into DIR/fit_<weighting>, and prints the recovered
eq. 4 coefficients against ``truth.json`` (goal: a1..a3 within 3 %, a0
within 10 %), the paper's fit-quality figures and the selection.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from drivebench.cli import main as bench
from fitting.efficiency import MaskingRules
from fitting.pipeline import FitOptions, run_fit

TOLERANCE = {"a0": 0.10, "a1": 0.03, "a2": 0.03, "a3": 0.03}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("raw", nargs="?", default="raw_measurements")
    parser.add_argument("--out", default=None, help="work directory (default: a temp dir)")
    args = parser.parse_args()
    raw = Path(args.raw)
    work = Path(args.out or tempfile.mkdtemp(prefix="fit_recovery_"))
    truth = json.loads((raw / "truth.json").read_text())
    ref = truth["reference_quadratic_rpm"]
    a_true = dict(zip(("a0", "a1", "a2", "a3"), (ref["a0_w"], ref["a1_w_per_rpm2"],
                      ref["a2_w_per_nm2"], ref["a3_w_per_rpm_nm"]), strict=True))
    store = work / "bench_store"
    t0 = time.perf_counter()
    if bench(["ingest", str(raw), "--store", str(store)]) != 0:
        return 1
    print(f"ingest: {time.perf_counter() - t0:.1f} s")
    ok = True
    for weighting in ("quadrant", "none"):
        t0 = time.perf_counter()
        summary = run_fit(store, work / f"fit_{weighting}",
                          FitOptions(order=2, weighting=weighting, masking=MaskingRules(),
                                     command_line=("benchmarks/fit_recovery.py", weighting)),
                          progress=False)
        elapsed = time.perf_counter() - t0
        st = summary["statistics"]
        print(f"\nweighting={weighting}: fit + selection + map + figures {elapsed:.1f} s")
        print(f"{'':>4} {'truth':>14} {'fit':>14} {'error %':>8} {'tol %':>6}")
        for (name, true), c in zip(a_true.items(), st["coefficients"], strict=True):
            err = 100 * (c["coef_rpm"] / true - 1)
            good = abs(err) <= 100 * TOLERANCE[name]
            ok &= good
            print(f"{name:>4} {true:>14.6g} {c['coef_rpm']:>14.6g} {err:>8.2f} "
                  f"{100 * TOLERANCE[name]:>6.0f} {'ok' if good else 'FAIL'}")
        r = st["residuals"]["all"]
        print(f"residual std {r['std_pct_nominal']:.2f} % of nominal (paper 1.6 %), "
              f"max {r['max_abs_pct_nominal']:.2f} % (paper < 5 %), R^2 {st['r2']:.5f}")
        print(f"selection: {st['selection']['reason']}")
        extra = summary["extra_terms_check"]
        for name, row in extra.get("paper_terms", {}).items():
            print(f"extra term {name}: {row['raw_orders_below_a1']:.1f} orders below a1 "
                  f"(raw rpm coefficients), {row['rated_orders_below_a1']:.1f} orders below "
                  f"a1*1500^2 at the rated corner")
    print(f"\noutputs under {work}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
