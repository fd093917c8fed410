"""``bench run PATH``: ingest, fit, optimize, aep, size and report in one go, with defaults.

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
    parser.add_argument("--weibull-k", default="2",
                        help="site for `bench aep` and `bench size`: Weibull shape (default 2)")
    parser.add_argument("--mean-speed", default="5.5",
                        help="site mean wind speed [m/s] at --site-height-m (default 5.5, the "
                             "paper's Leuven figure)")
    parser.add_argument("--site-height-m", default="100", help="site height [m] (default 100)")
    parser.add_argument("--no-refine", action="store_true",
                        help="`bench aep` on the sweep grid only, without --refine (the "
                             "added wind speeds where the curves bend; about 1.5 min of solves "
                             "on 2 workers for the default grid)")
    parser.add_argument("--size-scales", default="0.5,0.75,1,1.5",
                        help="torque-rating scales for `bench size` (default 0.5,0.75,1,1.5)")
    parser.add_argument("--size-wind-grid", default="5.5,7,8.5",
                        help="wind speeds of the sizing sweep (default 5.5,7,8.5)")


def stage_commands(args: argparse.Namespace) -> list[list[str]]:
    """Return the ``bench`` argument lists of the stages, in order."""
    out = args.out
    store, fit, opt = out / "bench_store", out / "fit", out / "optimize"
    aep, size = out / "aep", out / "size"
    site = ["--weibull-k", str(args.weibull_k), "--mean-speed", str(args.mean_speed),
            "--height-m", str(args.site_height_m)]
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
        ["aep", "--optimize", str(opt), "--out", str(aep), *site,
         *([] if args.no_refine else ["--refine", "--workers", str(args.workers)])],
        [
            "size",
            "--drive-model", str(fit / "power_model.json"),
            "--scales", args.size_scales,
            "--wind-grid", args.size_wind_grid,
            "--workers", str(args.workers),
            "--out", str(size),
            *site,
        ],
        [
            "report",
            "--store", str(store),
            "--fit", str(fit),
            "--optimize", str(opt),
            "--aep", str(aep),
            "--size", str(size),
            "--out", str(out / "report.html"),
        ],
    ]


def run(args: argparse.Namespace) -> int:
    """Run the stages one after the other; return the first non-zero exit code."""
    from bench.cli import main
    from optimize.cli import EXIT_SOME_FAILED

    for argv in stage_commands(args):
        print(f"\n== bench {' '.join(argv)}", flush=True)
        code = main(argv)
        if argv[0] == "optimize" and code == EXIT_SOME_FAILED:
            print("bench run: some scenarios failed (listed above); the next stages leave "
                  "them out and say so")
            continue
        if code:
            print(f"bench run: stage `{argv[0]}` failed with exit code {code}")
            return code
    print(f"\nbench run: report written to {(args.out / 'report.html').resolve()}")
    return 0
