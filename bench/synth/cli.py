"""``bench synth OUT_DIR``: write a deterministic synthetic bench campaign."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bench.synth.campaign import DEFAULT_SEED, generate, is_complete
from kernel.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``bench synth`` options."""
    parser.add_argument("out_dir", type=Path, metavar="OUT_DIR", help="campaign folder")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED,
                        help=f"random seed (default {DEFAULT_SEED})")
    parser.add_argument("--scale", type=int, default=1,
                        help="make the campaign N times longer (default 1); DAQ rows grow "
                        "by about 369 k per unit, so 55 gives 20.3 M")
    parser.add_argument("--check", action="store_true",
                        help="do nothing if OUT_DIR already holds this campaign, complete")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Generate (or verify) the campaign; print a one-line summary."""
    if args.scale < 1:
        raise InputError(None, f"--scale {args.scale} is not allowed", expected="an integer >= 1")
    if args.seed < 0:
        raise InputError(None, f"--seed {args.seed} is not allowed", expected="an integer >= 0")
    if args.out_dir.exists() and not args.out_dir.is_dir():
        raise InputError(args.out_dir, "exists and is not a directory",
                         expected="a campaign folder")
    if args.check and is_complete(args.out_dir, args.seed, args.scale):
        print(f"bench synth: {args.out_dir} is complete (seed {args.seed}, scale {args.scale})")
        return 0
    t0 = time.perf_counter()
    try:
        truth = generate(args.out_dir, args.seed, args.scale, progress=not args.quiet)
    except OSError as exc:
        raise InputError(exc.filename or args.out_dir, f"cannot write: {exc.strerror}",
                         expected="a writable campaign folder") from exc
    points = {"motor": 0, "generator": 0}
    faulty = 0
    for info in truth["sessions"].values():
        points[info["mode"]] += info["n_points"]
        faulty += len(info.get("bad_points", []))
    size = sum(f["bytes"] for f in truth["files"].values())
    rows = sum(i.get("daq_rows", 0) for i in truth["sessions"].values())
    cal = truth["calibration"]
    nominal = cal["nominal_power_w"]
    print(
        f"bench synth: wrote {args.out_dir} in {time.perf_counter() - t0:.1f} s: "
        f"{points['motor']} motor + {points['generator']} generator points "
        f"({faulty} of them faulty), "
        f"{rows} DAQ rows, {size / 1e6:.1f} MB; truth residual std "
        f"{100 * cal['residual_std_w'] / nominal:.2f} %, "
        f"max {100 * cal['residual_max_abs_w'] / nominal:.2f} % of {nominal / 1000:g} kW"
    )
    return 0
