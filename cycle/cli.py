"""``bench cycle export`` and ``bench cycle verify``: parse, call the library, print."""

from __future__ import annotations

import argparse
from pathlib import Path

from bench.cycle_profile import BenchFrame
from bench.ingest.session import load_session
from cycle.export import DEFAULT_EXPORT, ExportOptions, export_cycle

_D = DEFAULT_EXPORT


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register ``bench cycle export`` and ``bench cycle verify``."""
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    ex = sub.add_parser("export", help="a converged scenario as a drive profile for the bench",
                        allow_abbrev=False,
                        description="write a converged scenario of an optimize folder as a "
                        "drive profile (docs/schemas.md section 10) and its two plain tables")
    ex.add_argument("--optimize", type=Path, default=Path("optimize_out"),
                    help="output folder of `bench optimize` (default ./optimize_out)")
    ex.add_argument("--scenario", required=True, help="a converged scenario, e.g. elec-lim-7.0")
    ex.add_argument("--out", type=Path, default=Path("profile.csv"),
                    help="the profile CSV (default profile.csv); <stem>.speed.csv and "
                    "<stem>.torque.csv go beside it")
    ex.add_argument("--cycles", type=int, default=_D.n_cycles,
                    help=f"cycles in a row (default {_D.n_cycles})")
    ex.add_argument("--rate-hz", type=float, default=_D.rate_hz,
                    help=f"set-point rate [Hz] (default {_D.rate_hz:g})")
    ex.add_argument("--standstill-s", type=float, default=_D.standstill_s,
                    help=f"standstill before the ramp, the flange's tare [s] "
                    f"(default {_D.standstill_s:g})")
    ex.add_argument("--ramp-s", type=float, default=_D.ramp_s,
                    help=f"shortest ramp in and out [s] (default {_D.ramp_s:g}; longer when "
                    "the cycle's own largest rate needs it)")
    ex.add_argument("--bench-session", type=Path, default=None,
                    help="a session folder of the bench's campaign: the set-points are in its "
                    "frame (measured_side, gear_ratio, speed_sign, torque_sign of its "
                    "session.toml) and its drive rating and sensor ranges are limits too; "
                    "default the drum frame")


    ve = sub.add_parser("verify", help="measured energy per cycle against the predictions",
                        allow_abbrev=False,
                        description="per kept cycle of a cycle-run session in the store: the "
                        "measured electrical and mechanical energy with their uncertainty "
                        "against the power model at the measured speed and torque and against "
                        "the optimizer; mean error, 95 % band, drift, verdict "
                        "(docs/schemas.md section 11)")
    ve.add_argument("--store", type=Path, default=Path("bench_store"),
                    help="the store holding the cycle run (default ./bench_store)")
    ve.add_argument("--optimize", type=Path, default=Path("optimize_out"),
                    help="the optimize folder the profile was exported from "
                    "(default ./optimize_out)")
    ve.add_argument("--session", default=None,
                    help="the cycle-run session's id (default the store's only one)")
    ve.add_argument("--out", type=Path, default=Path("verify_out"),
                    help="output folder (default ./verify_out)")


def run(args: argparse.Namespace) -> int:
    """Run the action."""
    if args.action == "verify":
        return _verify(args)
    frame = BenchFrame()
    if args.bench_session is not None:
        s = load_session(args.bench_session)
        frame = BenchFrame(s.measured_side, s.gear_ratio, s.speed_sign, s.torque_sign)
    opts = ExportOptions(n_cycles=args.cycles, rate_hz=args.rate_hz,
                         standstill_s=args.standstill_s, ramp_s=args.ramp_s, frame=frame)
    done = export_cycle(args.optimize, args.scenario, args.out, opts,
                        bench_session=args.bench_session, command_line=args.command_line)
    h = done.profile.header
    print(f"bench cycle export: {h['scenario']}: {h['n_cycles']} cycles of "
          f"{h['period_s']:.3f} s at {h['rate_hz']:g} Hz, cycle 0 at {h['cycle_start_s']:.2f} s, "
          f"{done.profile.columns['time_s'][-1]:.1f} s in all; frame {h['measured_side']} "
          f"(gear ratio {h['gear_ratio']:g}, speed sign {h['speed_sign']:+d}, torque sign "
          f"{h['torque_sign']:+d})")
    print(f"  mechanical energy per cycle: profile {h['e_mech_profile_j']:.1f} J, optimizer "
          f"{h['e_mech_pred_j']:.1f} J (largest cycle difference "
          f"{100 * done.e_mech_error:.3f} %); electrical {h['e_elec_pred_j']:.1f} J predicted")
    print("  files: " + ", ".join(str(p) for p in done.files.values()))
    return 0


def _verify(args: argparse.Namespace) -> int:
    from cycle.verify_command import verify_cycles

    done = verify_cycles(args.store, args.optimize, args.out, session=args.session,
                         command_line=args.command_line)
    r, m = done.record, done.record["means"]
    print(f"bench cycle verify: session {r['session']} ({r['scenario']}): "
          f"{r['cycles_kept']} of {r['cycles_in_profile']} cycles kept; every mean, band "
          f"and the drift below is over these {m['n_cycles']}")
    for line in r["cycle_notes"]:
        print(f"  rejected {line}")
    print(f"  electrical energy per cycle: measured {m['e_elec_j']:.1f} +- "
          f"{m['band_elec_j']:.1f} J (95 %), power model at the measured speed and torque "
          f"{m['e_elec_model_j']:.1f} J, "
          f"optimizer {m['e_elec_optimizer_j']:.1f} J")
    print(f"  mechanical energy per cycle: measured {m['e_mech_j']:.1f} +- "
          f"{m['band_mech_j']:.1f} J (95 %), optimizer {r['e_mech_optimizer_j']:.1f} J")
    print(f"  {r['verdict']}")
    print(f"  files in {args.out}")
    return 0
