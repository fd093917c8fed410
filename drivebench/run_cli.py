"""``bench run PATH``: ingest, fit, optimize, aep, size and report in one go.

The stages still talk through files only: this command calls each stage's own
subcommand in turn, with every path under one output folder, and stops at the
first stage that fails. An option of ``bench run`` that a stage also has is
passed on only when the user gives it, so each stage keeps its own default (the
help below reads it from the stage). Two defaults are ``bench run``'s own: the
site (the paper's Leuven figure) and the optimize wind grid, which starts and
steps like ``bench optimize``'s default and ends where the site's wind ends
(:func:`energy.site.covering_stop`: above its last speed lies less than 1 % of the
site's available wind energy). ``bench size``'s own default grid covers the site by the
same rule, in coarser steps (:func:`energy.decision.covering_sizing_grid`).
"""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path

#: the site of ``bench run`` when none is given: Weibull k = 2, mean 5.5 m/s at 100 m
#: (the paper's Leuven figure)
DEMO_SITE = {"weibull_k": 2.0, "mean_speed": 5.5, "height_m": 100.0}
#: the stages that show a progress bar (``--no-progress``)
PROGRESS_STAGES = ("ingest", "fit", "optimize", "aep", "size")
#: ``bench run`` option -> (the stages that take it, their option): passed on only when given
FORWARDED = {
    "order": (("fit",), "--order"),
    "workers": (("ingest", "optimize", "aep", "size"), "--workers"),
    "size_scales": (("size",), "--scales"),
    "size_wind_grid": (("size",), "--wind-grid"),
    "system": (("optimize", "size"), "--system"),
    "call_time_limit": (("optimize", "aep", "size"), "--call-time-limit"),
}


def stage_parser(stage: str) -> argparse.ArgumentParser:
    """A parser with exactly the options of ``bench STAGE`` (its own defaults)."""
    from drivebench.cli import SUBCOMMANDS

    parser = argparse.ArgumentParser(prog=f"bench {stage}", allow_abbrev=False)
    importlib.import_module(SUBCOMMANDS[stage][0]).add_arguments(parser)
    return parser


def stage_default(stage: str, option: str):
    """The default of ``bench STAGE OPTION`` as that stage declares it."""
    return stage_parser(stage).get_default(option.lstrip("-").replace("-", "_"))


def _stage_defaults(stages: tuple[str, ...], option: str) -> str:
    """The stages' defaults of ``option`` in words: one value, or one per stage where they
    differ (None: a solve stage's worker count, the cores this process may use)."""
    by_value: dict[str, list[str]] = {}
    for s in stages:
        value = stage_default(s, option)
        by_value.setdefault("the cores this process may use" if value is None else str(value),
                            []).append(s)
    if len(by_value) == 1:
        return next(iter(by_value))
    return ", ".join(f"{'/'.join(s)} {w}" for w, s in by_value.items())


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``bench run`` options."""
    parser.add_argument("paths", nargs="+", type=Path, help="campaign folders with bench logs")
    parser.add_argument(
        "--out", type=Path, default=Path("bench_run"), help="output folder (default: ./bench_run)"
    )
    for dest, (stages, option) in FORWARDED.items():
        default = {"size_wind_grid": "the stage's, the grid that covers the site",
                   "system": "the stages', the shipped highwind.toml: the paper's kite"}.get(
            dest, f"the stage's, {_stage_defaults(stages, option)}")
        parser.add_argument("--" + dest.replace("_", "-"), default=None,
                            help=f"{option} of `bench {'/'.join(stages)}` (default: {default})")
    parser.add_argument(
        "--drive-model", type=Path, default=None,
        help="power model JSON the optimize and size stages fly instead of the one `bench fit` "
             "makes of the campaign (default: OUT/fit/power_model.json)")
    parser.add_argument(
        "--wind-grid", default=None,
        help="wind grid for `bench optimize` (default: from "
             f"{stage_default('optimize', '--wind-grid')} in the same steps up to the speed "
             "below which 99 %% of the site's wind energy lies)")
    parser.add_argument("--weibull-k", type=float, default=DEMO_SITE["weibull_k"],
                        help="site for `bench aep` and `bench size`: Weibull shape "
                             f"(default {DEMO_SITE['weibull_k']:g})")
    parser.add_argument("--mean-speed", type=float, default=DEMO_SITE["mean_speed"],
                        help="site mean wind speed [m/s] at --height-m (default "
                             f"{DEMO_SITE['mean_speed']:g}, the paper's Leuven figure)")
    parser.add_argument("--height-m", type=float, default=DEMO_SITE["height_m"],
                        help="height of the site's wind figures [m] (default "
                             f"{DEMO_SITE['height_m']:g})")
    parser.add_argument("--no-refine", action="store_true",
                        help="`bench aep` on the sweep grid only, without --refine (the "
                             "added wind speeds where the curves bend)")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress bar (--no-progress of every stage that shows one)")


def site_wind_grid(site_argv: list[str], system: Path | None = None) -> str:
    """A wind grid covering the site of the ``bench aep`` options ``site_argv``:
    ``START:STOP:STEP`` from the start of ``bench optimize``'s default grid in its steps,
    up to the speed below which 99 % of the site's available wind energy lies
    (:func:`energy.site.covering_stop`), at most to the 25 m/s cut-out of
    :data:`optimize.sweep_options.WIND_RANGE_M_S` (system files state no cut-out); the
    site moved to the reference height by ``system``'s wind profile (default the
    shipped system's)."""
    from energy.cli import shear_from_args, site_from_args
    from energy.site import covering_stop
    from optimize.door import WIND_RANGE_M_S, load_system, parse_wind_grid

    base = parse_wind_grid(stage_default("optimize", "--wind-grid"))
    start, step = base[0], base[1] - base[0]
    site_args = stage_parser("aep").parse_args(site_argv)
    site, _, _ = site_from_args(site_args, shear_from_args(site_args, load_system(system)))
    stop = covering_stop(site, start, step, ceiling_m_s=WIND_RANGE_M_S[1])
    return f"{start:g}:{stop:g}:{step:g}"


def stage_commands(args: argparse.Namespace) -> list[list[str]]:
    """Return the ``bench`` argument lists of the stages, in order."""
    out = args.out
    store, fit, opt = out / "bench_store", out / "fit", out / "optimize"
    aep, size = out / "aep", out / "size"
    site = ["--weibull-k", f"{args.weibull_k:g}", "--mean-speed", f"{args.mean_speed:g}",
            "--height-m", f"{args.height_m:g}"]
    given: dict[str, list[str]] = {s: [] for s in ("ingest", "fit", "optimize", "aep", "size")}
    for dest, (stages, option) in FORWARDED.items():
        for stage in stages if getattr(args, dest) is not None else ():
            given[stage] += [option, str(getattr(args, dest))]
    for stage in PROGRESS_STAGES if args.no_progress else ():
        given[stage].append("--no-progress")
    wind_grid = args.wind_grid or site_wind_grid(site, args.system)
    model = str(args.drive_model or fit / "power_model.json")
    return [
        ["ingest", *map(str, args.paths), "--store", str(store), *given["ingest"]],
        ["fit", "--store", str(store), "--out", str(fit), *given["fit"]],
        [
            "optimize",
            "--drive-model", model,
            "--wind-grid", wind_grid,
            "--out", str(opt),
            "--trust",  # a report to rely on states the mesh and simulation checks
            *given["optimize"],
        ],
        ["aep", "--optimize", str(opt), "--out", str(aep), *site,
         *([] if args.no_refine else ["--refine"]), *given["aep"]],
        ["size", "--drive-model", model, "--out", str(size), *site,
         *given["size"]],
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
    from drivebench.cli import main
    from optimize.door import EXIT_SOME_FAILED

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
