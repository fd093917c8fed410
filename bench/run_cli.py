"""``bench run PATH``: ingest, fit, optimize and report in one go, with defaults.

The stages still talk through files only: this command calls each stage's own
subcommand in turn, with every path under one output folder, and stops at the
first stage that fails.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``bench run`` options."""
    parser.add_argument("paths", nargs="+", type=Path, help="campaign folders with bench logs")
    parser.add_argument(
        "--out", type=Path, default=Path("bench_run"), help="output folder (default: ./bench_run)"
    )
    parser.add_argument("--order", default="2", help="power-model order for `bench fit`")
    parser.add_argument(
        "--wind-grid", default="4:10:1.5", help="wind grid for `bench optimize` (default 4:10:1.5)"
    )
    parser.add_argument("--workers", type=int, default=2, help="optimization worker processes")


def stage_commands(args: argparse.Namespace) -> list[list[str]]:
    """Return the ``bench`` argument lists of the four stages, in order."""
    out = args.out
    store, fit, opt = out / "bench_store", out / "fit", out / "optimize"
    return [
        ["ingest", *map(str, args.paths), "--store", str(store)],
        ["fit", "--store", str(store), "--out", str(fit), "--order", str(args.order)],
        [
            "optimize",
            "--drive-model", str(fit / "power_model.json"),
            "--wind-grid", args.wind_grid,
            "--workers", str(args.workers),
            "--out", str(opt),
            "--trust",  # a report to rely on states the mesh and simulation checks
        ],
        [
            "report",
            "--store", str(store),
            "--fit", str(fit),
            "--optimize", str(opt),
            "--out", str(out / "report.html"),
        ],
    ]


def run(args: argparse.Namespace) -> int:
    """Run the stages one after the other; return the first non-zero exit code."""
    from bench.cli import main

    for argv in stage_commands(args):
        print(f"\n== bench {' '.join(argv)}", flush=True)
        code = main(argv)
        if code:
            print(f"bench run: stage `{argv[0]}` failed with exit code {code}")
            return code
    print(f"\nbench run: report written to {(args.out / 'report.html').resolve()}")
    return 0
