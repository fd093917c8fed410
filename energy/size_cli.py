"""``bench size``: electrical AEP against drive rating over candidate drives.

A thin command line over :func:`energy.size_command.run_size` (the options here make the
site, :func:`energy.cli.site_from_args`); it writes ``size_out/sizing.json``,
``size_out/sizing.csv`` and the resumable solve store ``size_out/solves/``
(docs/schemas.md §8).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from energy.cli import add_site_arguments, shear_from_args, site_from_args
from kernel.errors import InputError
from optimize.door import failure_reason

#: where ``bench fit`` writes its model (docs/schemas.md §4)
FIT_MODEL_PATH = Path("fit_out") / "power_model.json"
DEFAULT_SCALES = "0.5,0.75,1,1.5,2"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``bench size``."""
    from optimize.door import add_call_time_limit

    parser.add_argument("--drive-model", type=Path, default=None,
                        help="reference drive's losses (power model JSON); default the system "
                             f"file's [drive] losses, else {FIT_MODEL_PATH} if it exists, else "
                             "the shipped paper model (the one used is printed)")
    parser.add_argument("--system", type=Path, default=None,
                        help="system file (kite, tether, winch, drive, wind, bounds; "
                             "docs/system_file.md); default the shipped highwind.toml. Its "
                             "[drive] is the reference drive x1")
    parser.add_argument("--scales", default=DEFAULT_SCALES,
                        help="torque-rating scales of the reference drive, comma list (default "
                             f"{DEFAULT_SCALES}); law in docs/schemas.md §8")
    parser.add_argument("--models", type=Path, nargs="*", default=(),
                        help="further candidates: power_model.json files (rated torque and "
                             "speed limit from their drive section, else the reference ones)")
    parser.add_argument("--continuous-torque-nm", type=float, default=None,
                        help="reference drive's continuous (RMS) torque rating [N m] (default: "
                             "the system's [drive] continuous_torque_nm, else its max_torque_nm)")
    parser.add_argument("--max-speed-rpm", type=float, default=None,
                        help="reference drive's speed limit [rpm] (default: the system's "
                             "[drive] max_speed_rpm)")
    parser.add_argument("--max-torque-nm", type=float, default=None,
                        help="reference drive's torque limit, its short-time peak [N m] "
                             "(default: the system's [drive] max_torque_nm, the limit bench "
                             "optimize flies)")
    parser.add_argument("--wind-grid", default=None,
                        help="wind speeds at the reference height [m/s], LO:HI:STEP or a comma "
                             "list (default: the grid that covers the site: from 4 m/s in 3 m/s "
                             "steps up to the speed below which 99 %% of the site's wind energy "
                             "lies; a grid that leaves out more than 1 %% of it gives no "
                             "decision)")
    parser.add_argument("--adaptive", action="store_true",
                        help="refine each candidate's wind grid where its power curve bends "
                             "(docs/schemas.md §9)")
    parser.add_argument("--extend", type=int, default=1, metavar="N",
                        help="when the best drive is the largest or smallest torque-rating "
                             "scale tried, add one scale beyond it and size again, up to N "
                             "times (default 1; 0: only flag it)")
    parser.add_argument("--tolerance", type=float, default=0.02,
                        help="choose the smallest drive within this share of the best AEP")
    parser.add_argument("--intervals", type=int, default=40, help="collocation intervals")
    parser.add_argument("--degree", type=int, default=4, help="Radau collocation degree")
    add_call_time_limit(parser)
    parser.add_argument("--workers", type=int, default=None,
                        help="local worker processes (default: the cores this process may use)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run on a Dask cluster at this scheduler address")
    parser.add_argument("--out", type=Path, default=Path("size_out"), help="output folder")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_site_arguments(parser)


def _scales(spec: str) -> tuple[float, ...]:
    """The numbers of ``--scales`` (checked as scales by :class:`SizingGrid`)."""
    try:
        return tuple(float(x) for x in spec.split(",") if x.strip())
    except ValueError:
        raise InputError(None, f"--scales {spec!r}: not numbers",
                         expected="a comma list of scales > 0") from None


def run(args: argparse.Namespace) -> int:
    """Run or resume the sizing sweep (:func:`energy.size_command.run_size`), print the
    table."""
    from energy.size_command import RatingOverrides, SizingGrid, run_size
    from energy.sizing import format_candidates, start_lines
    from optimize.door import Execution, SolverChoice, load_system, parse_wind_grid

    system = load_system(args.system)
    site, site_note, _ = site_from_args(args, shear_from_args(args, system))
    wind_speeds_m_s = None if args.wind_grid is None else parse_wind_grid(args.wind_grid)
    grid = SizingGrid(_scales(args.scales), tuple(args.models), wind_speeds_m_s,
                      args.tolerance, args.extend, args.adaptive)
    print(f"site: {site_note}")
    print(f"system: {system.name} ({system.path})")
    execution = Execution(args.workers, args.scheduler, progress=not args.no_progress)
    print(execution.line())
    done = run_size(site, args.drive_model, system=system, fit_default=FIT_MODEL_PATH,
                    grid=grid, out=args.out, site_note=site_note,
                    rating=RatingOverrides(continuous_torque_nm=args.continuous_torque_nm,
                                           max_speed_rpm=args.max_speed_rpm,
                                           max_torque_nm=args.max_torque_nm),
                    solver=SolverChoice(args.intervals, args.degree,
                                        call_time_limit_s=args.call_time_limit),
                    execution=execution,
                    command_line=args.command_line,
                    before_solving=lambda d, n, w: _announce(d, n, w, args.out,
                                                          system.drive.max_winding_temperature_c))
    res = done.sizing
    print(format_candidates(res.table))
    print(done.decision["line"])
    print(f"{res.n_solved} solved, {res.n_cached} loaded from the store, "
          f"{res.wall_time_s:.1f} s ({res.executor})")
    for line in start_lines(res.records):
        print(line)
    for n in done.notes:
        print(f"note: {n}")
    for r in (r for r in res.records if not r["success"]):
        print(f"FAILED: {r['candidate']} at {r['wind_speed_m_s']:g} m/s: {failure_reason(r)} "
              "(that candidate gets no AEP)")
    if done.kept is not None:
        print(f"bench size: {done.kept}", file=sys.stderr)
        return 1
    return 0 if res.chosen is not None else 1


def _announce(setup: Any, n_candidates: int, wind_speeds_m_s: tuple[float, ...], out: Path,
              winding_limit_c: float | None) -> None:
    from energy.decision import grid_spec

    for line in setup.resolution.lines(setup.drive):
        print(line)
    heat = winding_limit_c is not None and setup.drive.thermal_model is not None
    rating = (f"winding temperature <= {winding_limit_c:g} degC" if heat
              else "RMS torque <= the continuous rating where below the torque limit")
    print(f"{n_candidates} candidates x {len(wind_speeds_m_s)} wind speeds "
          f"({grid_spec(wind_speeds_m_s)} m/s; elec-lim, each the drive above "
          f"scaled: torque and speed limits, {rating}); solves stored in {out / 'solves'}")


