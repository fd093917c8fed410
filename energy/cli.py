"""``bench aep``: annual energy of the optimal power curves at a site (issue 12).

A thin command line over :func:`energy.site.read_histogram_csv`,
:func:`energy.curve.read_optimize_run`, :func:`energy.assess.assess` and
:func:`energy.outputs.write_outputs`.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from bench.errors import InputError

#: height of the optimize stage's wind speeds [m] (the kite model's wind reference)
DEFAULT_REFERENCE_HEIGHT_M = 100.0
#: roughness length of the logarithmic shear [m] (the kite model's wind shear, REFERENCE.md §2)
DEFAULT_ROUGHNESS_M = 0.1


def add_site_arguments(parser: argparse.ArgumentParser) -> None:
    """The site options shared by ``bench aep`` and ``bench size``."""
    g = parser.add_argument_group("site (one of --weibull-k, --rayleigh-mean, --histogram)")
    g.add_argument("--weibull-k", type=float, default=None, metavar="K",
                   help="Weibull shape; with --mean-speed or --scale")
    g.add_argument("--mean-speed", type=float, default=None, metavar="M_S",
                   help="mean wind speed [m/s] at --height-m (Weibull)")
    g.add_argument("--scale", type=float, default=None, metavar="M_S",
                   help="Weibull scale [m/s] at --height-m")
    g.add_argument("--rayleigh-mean", type=float, default=None, metavar="M_S",
                   help="Rayleigh site (Weibull k = 2) of this mean speed [m/s] at --height-m")
    g.add_argument("--histogram", type=Path, default=None, metavar="CSV",
                   help="wind-speed histogram CSV at --height-m (docs/schemas.md §7)")
    g.add_argument("--height-m", type=float, default=None,
                   help="height [m] the site is given at (default: the reference height)")
    g.add_argument("--reference-height-m", type=float, default=DEFAULT_REFERENCE_HEIGHT_M,
                   help="height of the optimize stage's wind speeds [m] (default 100)")
    g.add_argument("--roughness-m", type=float, default=DEFAULT_ROUGHNESS_M,
                   help="roughness length of the log shear used to move the site to the "
                        "reference height [m] (default 0.1, the kite model's)")
    g.add_argument("--mean-sigma", type=float, default=0.0, metavar="M_S",
                   help="one-sigma uncertainty of the mean speed [m/s] (Weibull/Rayleigh)")
    g.add_argument("--k-sigma", type=float, default=0.0,
                   help="one-sigma uncertainty of the Weibull shape")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``bench aep``."""
    parser.add_argument("--optimize", type=Path, default=Path("optimize_out"),
                        help="output folder of `bench optimize` (default ./optimize_out)")
    parser.add_argument("--drive-model", type=Path, default=None,
                        help="power model JSON (default: the one the sweep used, per its "
                             "manifest)")
    parser.add_argument("--nominal-power-w", type=float, default=None,
                        help="drive rating for the capacity factor [W] (default: the power "
                             "model's drive.nominal_power_w, else its nominal_power_w)")
    parser.add_argument("--out", type=Path, default=Path("aep_out"),
                        help="output folder (default ./aep_out)")
    add_site_arguments(parser)


def _positive(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(None, f"{name} {value}: not a positive number", expected="a value > 0")


def site_from_args(args: argparse.Namespace):
    """The site distribution at the reference height, a one-line note, and its uncertainty.

    Raises
    ------
    InputError
        No site, more than one, a missing or contradictory parameter, a bad value.
    """
    from energy.assess import SiteUncertainty
    from energy.site import Weibull, log_shear_factor, rayleigh, read_histogram_csv

    options = (("--weibull-k", args.weibull_k), ("--rayleigh-mean", args.rayleigh_mean),
               ("--histogram", args.histogram))
    given = [n for n, v in options if v is not None]
    expected = ("one site: --weibull-k K with --mean-speed M or --scale C, --rayleigh-mean M, "
                "or --histogram FILE")
    if len(given) != 1:
        listed = ", ".join(given) or "none"
        raise InputError(None, f"{len(given)} site definitions given ({listed})",
                         expected=expected)
    for name in ("weibull_k", "mean_speed", "scale", "rayleigh_mean", "height_m",
                 "reference_height_m", "roughness_m"):
        _positive("--" + name.replace("_", "-"), getattr(args, name))
    for name in ("mean_sigma", "k_sigma"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value >= 0):
            raise InputError(None, f"--{name.replace('_', '-')} {value}", expected="a value >= 0")
    height = args.reference_height_m if args.height_m is None else args.height_m
    if given[0] == "--weibull-k":
        if (args.mean_speed is None) == (args.scale is None):
            raise InputError(None, "--weibull-k needs exactly one of --mean-speed, --scale",
                             expected=expected)
        site = (Weibull.from_mean(args.weibull_k, args.mean_speed) if args.mean_speed is not None
                else Weibull(args.weibull_k, args.scale))
    elif given[0] == "--rayleigh-mean":
        if args.mean_speed is not None or args.scale is not None:
            raise InputError(None, "--rayleigh-mean takes no --mean-speed/--scale",
                             expected=expected)
        site = rayleigh(args.rayleigh_mean)
    else:
        if args.mean_speed is not None or args.scale is not None:
            raise InputError(None, "--histogram takes no --mean-speed/--scale", expected=expected)
        site = read_histogram_csv(args.histogram)
    note = f"{site.describe()} at {height:g} m"
    try:
        factor = log_shear_factor(height, args.reference_height_m, args.roughness_m)
    except ValueError as exc:
        raise InputError(None, str(exc), expected="heights above the roughness length") from exc
    unc = SiteUncertainty(args.mean_sigma * factor, args.k_sigma)
    if factor != 1.0:
        site = site.scaled(factor)
        note += (f"; moved to {args.reference_height_m:g} m by the log profile "
                 f"(z0 = {args.roughness_m:g} m, factor {factor:.4f}): {site.describe()}")
    return site, note, unc


def run(args: argparse.Namespace) -> int:
    """Compute and write the AEP assessment; print the table."""
    from energy.assess import assess
    from energy.curve import read_optimize_run
    from energy.outputs import SIGN_NOTE, format_table, write_outputs

    site, note, unc = site_from_args(args)
    if args.out.exists() and not args.out.is_dir():
        raise InputError(args.out, "exists and is not a folder", expected="an output folder")
    run_ = read_optimize_run(args.optimize)
    a = assess(run_, site, note, drive_model=args.drive_model,
               nominal_power_w=args.nominal_power_w, site_uncertainty=unc)
    write_outputs(a, run_, args.out, ["bench", "aep", *sys.argv[2:]], args.reference_height_m,
                  args.roughness_m)
    print(f"site: {note}")
    print(f"nominal power {a.nominal_power_w:.0f} W ({a.nominal_source})")
    print(format_table(a))
    print(SIGN_NOTE)
    for n in a.notes:
        print(f"note: {n}")
    print(f"files in {args.out}")
    return 0
