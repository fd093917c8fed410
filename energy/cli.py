"""``bench aep``: annual energy of the optimal power curves at a site.

A thin command line over :func:`energy.aep_command.run_aep`: the options here make the
site (:func:`site_from_args`) and the wind profile (:func:`shear_from_args`).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

from kernel.errors import InputError


def add_site_arguments(parser: argparse.ArgumentParser) -> None:
    """The site options shared by ``bench aep`` and ``bench size``."""
    g = parser.add_argument_group("site (one of --weibull-k, --rayleigh-mean, --histogram)")
    g.add_argument("--weibull-k", type=float, default=None, metavar="K",
                   help="Weibull shape; with --mean-speed or --weibull-scale")
    g.add_argument("--mean-speed", type=float, default=None, metavar="M_S",
                   help="mean wind speed [m/s] at --height-m (Weibull)")
    g.add_argument("--weibull-scale", type=float, default=None, metavar="M_S",
                   help="Weibull scale parameter c [m/s] at --height-m")
    g.add_argument("--rayleigh-mean", type=float, default=None, metavar="M_S",
                   help="Rayleigh site (Weibull k = 2) of this mean speed [m/s] at --height-m")
    g.add_argument("--histogram", type=Path, default=None, metavar="CSV",
                   help="wind-speed histogram CSV at --height-m (docs/schemas.md §7)")
    g.add_argument("--height-m", type=float, default=None,
                   help="height [m] the site is given at (default: the reference height)")
    g.add_argument("--reference-height-m", type=float, default=None,
                   help="height of the optimize stage's wind speeds [m] (default: the system "
                        "file's [wind] reference_height_m)")
    g.add_argument("--roughness-m", type=float, default=None,
                   help="roughness length of a log shear used to move the site to the "
                        "reference height [m] (default: the system file's [wind] profile)")
    g.add_argument("--mean-sigma", type=float, default=0.0, metavar="M_S",
                   help="one-sigma uncertainty of the mean speed [m/s] (Weibull/Rayleigh)")
    g.add_argument("--k-sigma", type=float, default=0.0,
                   help="one-sigma uncertainty of the Weibull shape")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``bench aep``."""
    from optimize.door import add_call_time_limit

    parser.add_argument("--optimize", type=Path, default=Path("optimize_out"),
                        help="output folder of `bench optimize` (default ./optimize_out)")
    parser.add_argument("--drive-model", type=Path, default=None,
                        help="power model JSON (default: the one the sweep used, per its "
                             "manifest)")
    parser.add_argument("--nominal-power-w", type=float, default=None,
                        help="drive rating for the capacity factor [W] (default: the drive in "
                             "force of the sweep, its manifest's sections.drive.nominal_power_w; "
                             "else the power model's)")
    parser.add_argument("--out", type=Path, default=Path("aep_out"),
                        help="output folder (default ./aep_out)")
    g = parser.add_argument_group("adaptive grid (docs/schemas.md §9)")
    g.add_argument("--refine", action="store_true",
                   help="solve added wind speeds where each kind's curve bends for this site, "
                        "until the interpolation error estimate is below --refine-tol; the "
                        "solves are stored in OUT/solves/ and reused by a re-run")
    g.add_argument("--refine-tol", type=float, default=None, metavar="SHARE",
                   help="stop when every interval's estimated error is below this share of "
                        "the AEP (default 0.002)")
    g.add_argument("--refine-max-points", type=int, default=25,
                   help="largest grid per kind, failed solves included (default 25)")
    g.add_argument("--workers", type=int, default=None,
                   help="worker processes for --refine (one kind per task; default: the cores "
                        "this process may use)")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address for --refine instead of the local pool")
    g.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_call_time_limit(g)
    add_site_arguments(parser)


#: plausible upper ends of site parameters: the windiest places measured have annual
#: mean wind speeds near 20 m/s (e.g. Cape Denison, Antarctica); roughness lengths of
#: terrain classes end near 2 m (city centres, WMO/Davenport classification)
MAX_MEAN_WIND_M_S = 30.0
MAX_ROUGHNESS_M = 5.0
#: plausible Weibull shapes: measured sites lie from about 1 (gusty, low mean) to about 4
#: (steady trade-wind sites); Rayleigh is 2
WEIBULL_K_RANGE = (0.5, 10.0)


def _at_most(name: str, value: float | None, limit: float, what: str) -> None:
    if value is not None and value > limit:
        raise InputError(None, f"{name} {value:g}: implausible", expected=f"{what} <= {limit:g}")


def _positive(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(None, f"{name} {value}: not a positive number", expected="a value > 0")


def shear_from_args(args: argparse.Namespace, system=None):
    """The wind profile: the system's ``[wind]`` (default the shipped system's), with
    ``--reference-height-m`` and ``--roughness-m`` (a log profile) over it when given."""
    from energy.site import Shear

    shear = Shear() if system is None else Shear.from_system(system.wind)
    if args.reference_height_m is not None:
        shear = dataclasses.replace(shear, reference_height_m=args.reference_height_m)
    if args.roughness_m is not None:
        shear = dataclasses.replace(shear, profile_kind="log", roughness_m=args.roughness_m,
                                    exponent=None)
    return shear


def site_from_args(args: argparse.Namespace, shear):
    """The site distribution at the reference height, a one-line note, and its uncertainty.

    ``shear`` (:class:`energy.site.Shear`, see :func:`shear_from_args`) moves a site given
    at ``--height-m`` to the reference height of the optimize stage's wind speeds.

    Raises
    ------
    InputError
        No site, more than one, a missing or contradictory parameter, a bad value.
    """
    from energy.assess import SiteUncertainty
    from energy.site import Weibull, rayleigh, read_histogram_csv

    options = (("--weibull-k", args.weibull_k), ("--rayleigh-mean", args.rayleigh_mean),
               ("--histogram", args.histogram))
    given = [n for n, v in options if v is not None]
    expected = ("one site: --weibull-k K with --mean-speed M or --weibull-scale C, "
                "--rayleigh-mean M, or --histogram FILE")
    if len(given) != 1:
        listed = ", ".join(given) or "none"
        raise InputError(None, f"{len(given)} site definitions given ({listed})",
                         expected=expected)
    for name in ("weibull_k", "mean_speed", "weibull_scale", "rayleigh_mean", "height_m",
                 "reference_height_m", "roughness_m"):
        _positive("--" + name.replace("_", "-"), getattr(args, name))
    for name in ("mean_speed", "weibull_scale", "rayleigh_mean"):
        _at_most("--" + name.replace("_", "-"), getattr(args, name), MAX_MEAN_WIND_M_S,
                 "a site's wind speed [m/s]")
    _at_most("--roughness-m", args.roughness_m, MAX_ROUGHNESS_M, "a roughness length [m]")
    lo, hi = WEIBULL_K_RANGE
    if args.weibull_k is not None and not lo <= args.weibull_k <= hi:
        raise InputError(None, f"--weibull-k {args.weibull_k:g}: implausible Weibull shape",
                         expected=f"a shape from {lo:g} to {hi:g} (measured sites: about 1 "
                                  "to 4; Rayleigh, --rayleigh-mean, is 2)")
    if args.roughness_m is not None and args.roughness_m >= min(
            shear.reference_height_m, args.height_m or math.inf):
        raise InputError(None, f"--roughness-m {args.roughness_m:g}: not below the heights "
                         "of the log profile", expected="a roughness length below "
                         f"{min(shear.reference_height_m, args.height_m or math.inf):g} m")
    for name in ("mean_sigma", "k_sigma"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value >= 0):
            raise InputError(None, f"--{name.replace('_', '-')} {value}", expected="a value >= 0")
    ref = shear.reference_height_m
    height = ref if args.height_m is None else args.height_m
    if given[0] == "--weibull-k":
        if (args.mean_speed is None) == (args.weibull_scale is None):
            raise InputError(None, "--weibull-k needs exactly one of --mean-speed, "
                             "--weibull-scale",
                             expected=expected)
        site = (Weibull.from_mean(args.weibull_k, args.mean_speed) if args.mean_speed is not None
                else Weibull(args.weibull_k, args.weibull_scale))
    elif given[0] == "--rayleigh-mean":
        if args.mean_speed is not None or args.weibull_scale is not None:
            raise InputError(None, "--rayleigh-mean takes no --mean-speed/--weibull-scale",
                             expected=expected)
        site = rayleigh(args.rayleigh_mean)
    else:
        if args.mean_speed is not None or args.weibull_scale is not None:
            raise InputError(None, "--histogram takes no --mean-speed/--weibull-scale",
                             expected=expected)
        site = read_histogram_csv(args.histogram)
    note = f"{site.describe()} at {height:g} m"
    try:
        factor = shear.profile(ref) / shear.profile(height)
    except ValueError as exc:
        raise InputError(None, str(exc), expected="heights above ground") from exc
    unc = SiteUncertainty(args.mean_sigma * factor, args.k_sigma)
    if factor != 1.0:
        site = site.scaled(factor)
        note += (f"; moved to {ref:g} m by the {shear.describe()} (factor {factor:.4f}): "
                 f"{site.describe()}")
    return site, note, unc


def run(args: argparse.Namespace) -> int:
    """Compute and write the AEP assessment (:func:`energy.aep_command.run_aep`); print
    the table."""
    from energy.aep_command import RefineOptions, SiteSpec, run_aep
    from energy.outputs import SIGN_NOTE, format_table
    from energy.refine import DEFAULT_TOL, added_list, system_from_manifest
    from optimize.door import Execution
    from optimize.sweep_folder import read_manifest

    if args.out.exists() and not args.out.is_dir():
        raise InputError(args.out, "exists and is not a folder", expected="an output folder")
    refine = (RefineOptions(DEFAULT_TOL if args.refine_tol is None else args.refine_tol,
                            args.refine_max_points, args.call_time_limit)
              if args.refine else None)
    manifest = read_manifest(Path(args.optimize))
    shear = shear_from_args(args, system_from_manifest(manifest,
                                                       Path(args.optimize) / "manifest.json"))
    site, note, unc = site_from_args(args, shear)
    execution = Execution(args.workers, args.scheduler, not args.no_progress)
    if refine is not None:
        print(execution.line())
    result = run_aep(args.optimize, SiteSpec(site, note, unc, shear), out=args.out,
                     drive_model=args.drive_model, nominal_power_w=args.nominal_power_w,
                     refine=refine, command_line=args.command_line,
                     execution=execution)
    a, refined = result.assessment, result.refined
    if refined is not None:
        print(f"refined grid ({refined.n_solved} solved, {refined.n_loaded} loaded from "
              f"{args.out / 'solves'}, {refined.wall_time_s:.0f} s on {refined.executor}):")
        for kind, k in result.refine_document["kinds"].items():
            print(f"  {kind:<10} AEP el {k['coarse_aep_elec_mwh']:.4f} -> "
                  f"{k['aep_elec_mwh']:.4f} MWh/yr, mech {k['coarse_aep_mech_mwh']:.4f} -> "
                  f"{k['aep_mech_mwh']:.4f}; added {added_list(k)}")
    print(f"site: {note}")
    print(f"nominal power {a.nominal_power_w:.0f} W ({a.nominal_source})")
    print(format_table(a))
    print(SIGN_NOTE)
    for n in a.notes:
        print(f"note: {n}")
    print(f"files in {args.out}")
    return 0
