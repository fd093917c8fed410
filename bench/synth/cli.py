"""``bench synth OUT_DIR``: write a deterministic synthetic bench campaign."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bench.synth.campaign import DEFAULT_SEED, generate, is_complete
from kernel.errors import InputError
from kernel.output_place import check_place


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
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--cycle-run", type=Path, default=None, metavar="PROFILE",
                        help="instead of the campaign: fly this drive profile (bench cycle "
                        "export) on the campaign's true drive into OUT_DIR/<--session-id>/, "
                        "its truth in cycle_truth.json beside it")
    parser.add_argument("--session-id", default="cycle_01",
                        help="the cycle-run session's id and folder (default cycle_01)")
    parser.add_argument("--truth", type=Path, default=None,
                        help="with --cycle-run: the campaign truth.json whose loss model is "
                        "the drive's (default OUT_DIR/truth.json)")


def run(args: argparse.Namespace) -> int:
    """Generate (or verify) the campaign; print a one-line summary."""
    if args.scale < 1:
        raise InputError(None, f"--scale {args.scale} is not allowed", expected="an integer >= 1")
    if args.seed < 0:
        raise InputError(None, f"--seed {args.seed} is not allowed", expected="an integer >= 0")
    if args.out_dir.exists() and not args.out_dir.is_dir():
        raise InputError(args.out_dir, "exists and is not a directory",
                         expected="a campaign folder")
    check_place(args.out_dir, "OUT_DIR", itself=True)  # not a stage's output or store
    if args.cycle_run is not None:
        return _cycle_run(args)
    if args.check and is_complete(args.out_dir, args.seed, args.scale):
        print(f"bench synth: {args.out_dir} is complete (seed {args.seed}, scale {args.scale})")
        return 0
    t0 = time.perf_counter()
    try:
        truth = generate(args.out_dir, args.seed, args.scale, progress=not args.no_progress)
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


def _cycle_run(args: argparse.Namespace) -> int:
    """``--cycle-run``: write the cycle-run session and print its truth in one line."""
    import dataclasses

    from bench.synth.cycle_session import CycleRunSpec, write_cycle_run

    if not args.session_id.replace("_", "").replace("-", "").isalnum():
        raise InputError(None, f"--session-id {args.session_id!r}",
                         expected="letters, digits, '_' or '-' (a folder name)")
    run = dataclasses.replace(CycleRunSpec(), session_id=args.session_id, seed=args.seed)
    truth = write_cycle_run(args.out_dir, args.cycle_run, run, truth_path=args.truth)
    e = truth["cycles"]["e_elec_j"]
    print(f"bench synth: wrote {args.out_dir / args.session_id}: {len(e)} cycles of "
          f"{truth['scenario']}, true electrical energy per cycle {min(e):.1f} to "
          f"{max(e):.1f} J (cycle_truth.json)")
    return 0
