"""``bench optimize``: the pumping-cycle sweep over a wind grid.

Parses the options into the sweep's option objects (:mod:`optimize.sweep_options`),
checks the inputs (:func:`optimize.command.make_request`), runs the sweep
(:func:`optimize.command.run_optimize`: plan chains, run them on the solve service,
compare with the paper, write the files) and prints the summary, claims and trust figures.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any

from kernel.errors import InputError
from optimize.kinds import DEFAULT_KINDS
from optimize.problem.deadline import (
    CALL_WALL_LIMIT_S,
    COLD_START_CALLS,
    HARD_STOP_CALLS,
    HARD_STOP_GRACE_S,
    SCENARIO_CALLS,
)
from optimize.problem.options import SOLVERS, TRANSCRIPTIONS
from optimize.sweep_options import DEFAULT_WIND_GRID, GIVE_UP_AFTER

log = logging.getLogger(__name__)

#: where ``bench fit`` writes its model (docs/schemas.md §4)
FIT_MODEL_PATH = Path("fit_out") / "power_model.json"
#: exit codes of ``bench optimize`` (2, bad input, is every stage's: :mod:`drivebench.cli`)
EXIT_ALL_CONVERGED, EXIT_ALL_FAILED, EXIT_SOME_FAILED, EXIT_CLUSTER_LOST = 0, 1, 3, 4
EXIT_CODES = (f"exit codes: {EXIT_ALL_CONVERGED} every scenario converged; {EXIT_SOME_FAILED} "
              f"some failed (listed after FAILED, their status in summary.parquet; the files "
              f"are written); {EXIT_ALL_FAILED} all failed ({EXIT_SOME_FAILED} or "
              f"{EXIT_ALL_FAILED} also when the run stopped itself, the scenarios not run "
              "listed: WORKER LOST, a solver call hung; STOPPED, a solver other than IPOPT "
              f"failed {GIVE_UP_AFTER} scenarios and converged none); {EXIT_CLUSTER_LOST} the Dask "
              "cluster was lost during the run (the scenarios that finished are written, "
              "the others listed as not run; an earlier output with scenarios this run lost "
              "is kept, this one written beside it as <out>.partial); 2 bad input (nothing "
              "solved, nothing written)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``bench optimize``."""
    parser.epilog = EXIT_CODES
    parser.add_argument(
        "--drive-model",
        type=Path,
        default=None,
        help="the drive's losses: a power model JSON (bench fit), overriding the system "
        f"file's [drive] losses; default those, else {FIT_MODEL_PATH} if it exists, else the "
        "shipped paper Table I model. The rating in force is the system file's [drive]",
    )
    parser.add_argument(
        "--system",
        type=Path,
        default=None,
        help="system file (TOML: kite, aero, tether, winch, drive, wind, bounds; "
        "docs/system_file.md); default the shipped highwind.toml, the paper's kite",
    )
    parser.add_argument(
        "--wind-grid",
        default=DEFAULT_WIND_GRID,
        help="wind speeds at 100 m [m/s]: START:STOP:STEP with both ends included, or a "
        f"comma list (default {DEFAULT_WIND_GRID})",
    )
    parser.add_argument(
        "--scenarios",
        default=DEFAULT_KINDS,
        help=f"comma list of scenario kinds (default {DEFAULT_KINDS})",
    )
    parser.add_argument("--intervals", type=int, default=40, help="collocation intervals")
    parser.add_argument("--degree", type=int, default=4, help="Radau collocation degree")
    parser.add_argument("--workers", type=int, default=None,
                        help="local worker processes (default: the cores this process may use)")
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on a Dask cluster at this scheduler address instead (needs drivebench[dask])",
    )
    parser.add_argument("--out", type=Path, default=Path("optimize_out"), help="output folder")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--no-claims", action="store_true", help="skip the cut-in search and the paper comparison"
    )
    _add_solver_arguments(parser)
    parser.add_argument(
        "--trust",
        action="store_true",
        help="also run the trust checks (mesh refinement at 2x intervals, CVODES simulation)",
    )
    parser.add_argument(
        "--period-scan",
        type=int,
        nargs="?",
        const=4,
        default=0,
        metavar="N",
        help="look for a better optimum along the period: solve each converged scenario "
        "again with its period held at N other values (default 4; from half to twice its "
        "own, within the system's period bounds), then free; the best is kept (2 N warm "
        "solves per scenario; the local-optimum check compares wind speeds and cannot "
        "check a kind of fewer than 3)",
    )


def _add_solver_arguments(parser: argparse.ArgumentParser) -> None:
    """Register how ``bench optimize`` solves: solver, transcription, generated code,
    linear solver and start."""
    parser.add_argument(
        "--solver",
        choices=SOLVERS,
        default="ipopt",
        help="NLP solver: ipopt (default: IPOPT on the general sparse layout) or fatrop "
        "(Riccati-based, on a stage-wise layout of the same NLP; see benchmarks/README.md "
        "for how the two compare here)",
    )
    parser.add_argument(
        "--transcription",
        choices=TRANSCRIPTIONS,
        default="collocation",
        help="what the solver runs on: collocation (default: the states and algebraic "
        "variables at every Radau point are NLP variables) or condensed (multiple shooting, "
        "each interval's collocation solved inside the interval; the same optima, see "
        "benchmarks/README.md for the time)",
    )
    parser.add_argument(
        "--codegen",
        action="store_true",
        help="compile the NLP's repeated functions to C with the system's C compiler "
        "($CC, gcc or cc; cached in ~/.cache/drivebench/casadi, so only the first use of a "
        "model compiles); without a compiler they run uncompiled and a warning says so",
    )
    parser.add_argument(
        "--linear-solver",
        default=None,
        metavar="NAME",
        help="IPOPT's linear solver: mumps (default), spral, or where you installed HSL "
        "(libhsl.so on LD_LIBRARY_PATH) ma27, ma57, ma77, ma86, ma97, or pardiso "
        "(libpardiso.so); checked before any solve (exit 2 when IPOPT cannot load it)",
    )
    add_call_time_limit(parser)
    parser.add_argument(
        "--no-stored-guess",
        action="store_true",
        help="start every chain by the homotopy, not from the shipped initial guess",
    )
    parser.add_argument(
        "--start",
        type=Path,
        default=None,
        metavar="PATH",
        help="start the sweep from an earlier sweep of the same system file: its folder "
        "or its start.npz (refused, exit 2, for another system), instead of the shipped "
        "initial guess or the homotopy",
    )


def add_call_time_limit(parser: Any) -> None:
    """Register ``--call-time-limit SECONDS`` on ``parser`` (an argument parser or group):
    the one definition of the option of every command that solves (``bench optimize``,
    ``bench size``, ``bench aep --refine``),
    :attr:`optimize.problem.options.SolverOptions.call_time_limit_s`, which refuses a
    value that is not positive (:func:`check_call_time_limit`)."""
    parser.add_argument(
        "--call-time-limit",
        type=float,
        default=CALL_WALL_LIMIT_S,
        metavar="SECONDS",
        help=f"the longest one solver call may run, wall clock (default {CALL_WALL_LIMIT_S:g}); "
        f"a solve (a cold start, or a warm one with its steps and retry) may run "
        f"{COLD_START_CALLS} times as long, and a scenario's solver runs all together "
        f"(warm, cold, retries, re-solves) start within {SCENARIO_CALLS} times as long, the "
        "last ending within one more (bench optimize states the bound this sets before it "
        "starts); a solve stopped so fails with the status Wall_Time_Limit; a call still "
        f"running {HARD_STOP_CALLS} times as long and {HARD_STOP_GRACE_S:g} s more is taken "
        "to hang and stops the run, what finished kept. Raise it for a large mesh or a slow "
        "or loaded machine; inf: no limit (and no bound)",
    )


def check_call_time_limit(seconds: float) -> None:
    """Refuse a ``--call-time-limit`` that ``SolverOptions`` refuses, as ``bench optimize``
    does (:class:`kernel.errors.InputError`, exit 2, before any work)."""
    from optimize.problem.options import SolverOptions

    try:
        SolverOptions(call_time_limit_s=seconds)
    except ValueError as exc:
        raise InputError(None, f"OCP options: {exc}") from exc


def run(args: argparse.Namespace) -> int:
    """Run the sweep (:func:`optimize.command.run_optimize`); the exit code says how many
    scenarios converged, or that the Dask cluster was lost (:data:`EXIT_CODES`)."""
    from optimize.command import format_summary, make_request, run_optimize
    from optimize.service.outcome import NOT_RUN
    from optimize.sweep_options import Execution, SolverChoice, WindGrid

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    execution = Execution(args.workers, args.scheduler, progress=not args.no_progress)
    request = make_request(
        WindGrid.parse(args.wind_grid, args.scenarios),
        SolverChoice(args.intervals, args.degree, args.solver, args.linear_solver,
                     not args.no_stored_guess, args.transcription, args.codegen,
                     args.start, args.call_time_limit),
        drive_model=args.drive_model, system=args.system, fit_default=FIT_MODEL_PATH, out=args.out,
        execution=execution, claims=not args.no_claims, trust=args.trust,
        period_scan=args.period_scan)
    print(request.model_note)
    print(execution.line())
    print(request.time_bound())
    sweep = run_optimize(request, list(args.command_line), show_progress=not args.no_progress)
    print(format_summary(sweep.summary, args.period_scan,
                         (request.setup.system.bounds.period_min_s,
                          request.setup.system.bounds.period_max_s)))
    if sweep.claims is not None:
        from optimize.analysis.claims import format_claims

        print()
        print(format_claims(sweep.claims))
    for line in sweep.trust_lines:
        print(line)
    n_ok = int(sweep.summary["success"].sum())
    print(f"\n{iterations_line(sweep.iterations, args.solver)}")
    print(f"{n_ok}/{len(sweep.summary)} scenarios converged in {sweep.wall_time_s:.1f} s "
          f"({sweep.executor}); files in {sweep.out or args.out}")
    not_run = sweep.summary["status"].str.startswith(NOT_RUN)
    failed = sweep.summary.loc[~sweep.summary["success"] & ~not_run, "scenario"].tolist()
    if failed:
        print(f"FAILED (status in summary.parquet, never averaged): {', '.join(failed)}")
        advice = solver_advice(args.solver, args.transcription)
        if advice:
            print(advice)
    if sweep.lost is None:
        return exit_code(sweep.summary["success"].tolist())
    # a stop the run decided (a hung call, a solver given up) may come again on a re-run:
    # the scenarios' own exit code; a lost cluster's scenarios a re-run solves
    label, again = ((sweep.stopped, "the run stopped") if sweep.stopped else
                    ("CLUSTER LOST", "cluster lost; a re-run solves them"))
    print(f"{label}: {sweep.lost}", file=sys.stderr)
    print(f"NOT RUN ({again}): "
          f"{', '.join(sweep.summary.loc[not_run, 'scenario']) or 'none of the scenarios'}",
          file=sys.stderr)
    if sweep.kept:
        print(sweep.kept, file=sys.stderr)
    return exit_code(sweep.summary["success"].tolist()) if sweep.stopped else EXIT_CLUSTER_LOST


def solver_advice(solver: str, transcription: str) -> str | None:
    """What to do about the failed scenarios of a sweep solved by ``solver`` on
    ``transcription`` (``--solver``, ``--transcription``); None with IPOPT."""
    if solver == "ipopt":
        return None
    how = ("; on the condensed NLP its steps reach points where an interval's Newton solve "
           "diverges, and its homotopy stalls there" if transcription == "condensed" else "")
    return (f"{solver} failed them: on this OCP it fails from starts IPOPT solves (it takes no "
            f"dual warm start{how}; measured in benchmarks/README.md). Use --solver ipopt (the "
            "default): the paper sweep converges 20/20 with it, on either transcription")


#: the solvers' names as their authors write them (``--solver``)
SOLVER_NAMES = {"ipopt": "IPOPT", "fatrop": "fatrop"}


def iterations_line(iterations: dict, solver: str = "ipopt") -> str:
    """What the sweep's solves cost in iterations of ``solver`` (``--solver``), in one
    line."""
    way = (f"; {iterations['intermediate_points']} intermediate points on the way to them "
           f"({iterations['intermediate_iterations']} iterations, not results)"
           if iterations["intermediate_iterations"] else "")
    roles = ", ".join(f"{role} {n}" for role, n in iterations.get("by_role", {}).items())
    return (f"{SOLVER_NAMES.get(solver, solver)} iterations: {iterations['reported']} in the "
            f"scenarios' final solves{way}; "
            f"{iterations['all']} in all" + (f" ({roles})" if roles else ""))


def exit_code(success: list[bool]) -> int:
    """:data:`EXIT_ALL_CONVERGED`, :data:`EXIT_SOME_FAILED` or :data:`EXIT_ALL_FAILED`."""
    if all(success):
        return EXIT_ALL_CONVERGED
    return EXIT_SOME_FAILED if any(success) else EXIT_ALL_FAILED
