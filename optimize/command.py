"""The whole ``bench optimize`` command as a library call: :func:`run_optimize`.

Plan the chains (:mod:`optimize.service.plan`), run them on the solve service
(:mod:`optimize.service`, on :mod:`optimize.service.executors`), the trust
checks (:mod:`optimize.sweep.trust`), the paper comparison
(:mod:`optimize.analysis.claims`) and the files (:mod:`optimize.sweep_folder`).
This module sits above the solver and the analysis; nothing in them imports it.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kernel.errors import InputError
from kernel.files import check_output_dir, file_sha256
from kernel.output_folder import check_replaceable
from kernel.provenance import Provenance
from optimize.analysis.claims import cut_in_frame, evaluate_claims
from optimize.analysis.result_check import MIN_COLLOCATION_POINTS, mesh_label
from optimize.kinds import KINDS
from optimize.problem.deadline import CALL_WALL_LIMIT_S, SCENARIO_CALLS, hard_stop_s
from optimize.problem.ocp import model_parts
from optimize.problem.part import trajectory_columns
from optimize.resolve import Setup, resolve
from optimize.service import Problem, SweepTasks, run_sweep
from optimize.service.builder import OcpBackend
from optimize.service.cut_in import max_probes
from optimize.service.executors import open_executor
from optimize.service.plan import plan_graph
from optimize.solve.starts.stored_guess import check_start_file
from optimize.solve.starts.stored_guess import write as write_start
from optimize.sweep import outputs
from optimize.sweep.trust import run_trust_checks
from optimize.sweep_folder import (
    FINER_MESH_HEAD,
    MARKERS,
    START_FILE,
    bound_lines,
    domain_lines,
    remesh_lines,
    resolve_lines_of,
    unchecked_head,
    unchecked_lines,
    write_sweep_folder,
)
from optimize.sweep_options import (
    DEFAULT_SOLVER,
    GIVE_UP_AFTER,
    LOCAL_POOL,
    PAPER_GRID,
    Execution,
    SolverChoice,
    WindGrid,
)
from optimize.system.contradictions import check_drive
from optimize.system.system import System


@dataclass(frozen=True)
class SweepRequest:
    """Everything ``bench optimize`` was asked to do (see :func:`run_optimize`).

    Attributes
    ----------
    grid : WindGrid
        Wind speeds [m/s] and scenario kinds.
    setup : optimize.resolve.Setup
        The system, the drive in force (rating, losses) and the OCP options
        (:func:`optimize.resolve.resolve`).
    model_note : str
        What the setup is and why (printed and recorded).
    workers : int
        Local worker processes (ignored with ``scheduler``).
    scheduler : str or None
        Dask scheduler address.
    out : Path
        Output folder.
    claims : bool
        Run the cut-in searches and the paper comparison.
    trust : bool
        Run the mesh and simulation checks.
    cut_in_tol_m_s : float
        Cut-in bisection stops at this bracket width [m/s].
    period_scan : int
        Held periods per converged scenario of the period scan (0: none;
        :mod:`optimize.service.period_scan`).
    """

    grid: WindGrid
    setup: Setup
    model_note: str
    workers: int = 2
    scheduler: str | None = None
    out: Path = Path("optimize_out")
    claims: bool = True
    trust: bool = False
    cut_in_tol_m_s: float = 0.05
    period_scan: int = 0

    @property
    def cut_in_kinds(self) -> tuple[str, ...]:
        """The kinds whose cut-in speed is searched: the drive-limited ones, with claims."""
        return (tuple(k for k in self.grid.kinds if KINDS[k].drive_limits)
                if self.claims else ())

    def time_bound(self) -> str:
        """The most the sweep's solver runs take, in one line, said before it starts: each
        scenario's runs (the grid's and the cut-in probes') start within
        :data:`~optimize.problem.deadline.SCENARIO_CALLS` call limits and the last ends
        within one more (:class:`optimize.service.solves.Solves`); a call that hangs ends
        the run at its hard stop (:func:`optimize.problem.deadline.hard_stop_s`)."""
        limit_s = self.setup.options.solver.call_time_limit_s
        if not math.isfinite(limit_s):
            return "time bound: none (--call-time-limit inf: no solver run is stopped)"
        n_grid = len(self.grid.wind_speeds_m_s) * len(self.grid.kinds)
        n_probes = len(self.cut_in_kinds) * max_probes(self.grid.wind_speeds_m_s,
                                                       self.cut_in_tol_m_s)
        per_s = (SCENARIO_CALLS + 1) * limit_s
        probes = f" and up to {n_probes} cut-in probes" if n_probes else ""
        scenarios = f"{n_grid} scenario{'s' * (n_grid != 1)}"
        return (f"time bound: {scenarios}{probes}, each at most {per_s:g} s of solver runs "
                f"({SCENARIO_CALLS} + 1 times --call-time-limit {limit_s:g}), "
                f"{_minutes((n_grid + n_probes) * per_s)} in all (NLP builds and --trust "
                f"aside); a call that hangs stops the run {hard_stop_s(limit_s):g} s after "
                "it began")


def _minutes(seconds: float) -> str:
    """``seconds`` [s] in words: ``"270 s"``, ``"18 min"``, ``"2.5 h"``."""
    if seconds < 600:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.0f} min" if seconds < 3 * 3600 else f"{seconds / 3600:.1f} h"


#: the most held periods ``--period-scan`` takes (each costs two warm solves per scenario)
MAX_PERIOD_SCAN = 8


def make_request(grid: WindGrid = PAPER_GRID, solver: SolverChoice = DEFAULT_SOLVER, *,
                 drive_model: Any = None, system: Path | System | None = None,
                 fit_default: Path | None = None, out: Path = Path("optimize_out"),
                 execution: Execution = LOCAL_POOL, claims: bool = True,
                 trust: bool = False, period_scan: int = 0) -> SweepRequest:
    """The request of a sweep, every input checked before any solve.

    Parameters
    ----------
    grid : WindGrid
        Wind speeds [m/s] and scenario kinds.
    solver : SolverChoice
        Collocation intervals (2 to :data:`optimize.problem.options.MAX_INTERVALS`, half
        that with ``trust``, which refines to twice as many), Radau degree (1 to 9), and
        the solver (:func:`solver_options`).
    drive_model : Path or PowerModel, optional
        The drive's losses (``--drive-model``, or a model object), overriding the system
        file's. A model object is written into the output folder with the results.
    system : Path or System, optional
        The system (``--system``); default the shipped ``highwind.toml``.
    fit_default : Path, optional
        ``bench fit``'s model, used when it exists and neither ``drive_model`` nor the system
        file names the losses (:func:`optimize.system.drive_in_force.drive_in_force`).
    out : Path
        Output folder (must be a folder or absent).
    execution : Execution
        Worker processes or a Dask scheduler (the progress bar is :func:`run_optimize`'s).
    claims, trust
        As :class:`SweepRequest`.
    period_scan : int
        Held periods per converged scenario of the period scan (``--period-scan``, 0 to
        :data:`MAX_PERIOD_SCAN`; 0: none).

    Raises
    ------
    InputError
        Any input out of range or unreadable; a drive model that is physically
        impossible, a drive that cannot hold the kite, or bounds of different parts that
        cannot hold together (:func:`optimize.system.contradictions.check_drive`).
    """
    from optimize.problem.options import Discretization, OcpOptions

    _check_ranges(solver, trust, period_scan)
    check_output_dir(out)
    start = start_file(solver.start)
    try:
        options = OcpOptions(Discretization(n_intervals=solver.n_intervals,
                                            degree=solver.degree),
                             solver=solver_options(solver.solver, solver.linear_solver,
                                                   solver.stored_guess, solver.transcription,
                                                   solver.codegen, start,
                                                   solver.call_time_limit_s))
    except ValueError as exc:
        raise InputError(None, f"OCP options: {exc}") from exc
    setup = resolve(system, drive_model, fit_default=fit_default, options=options)
    loaded, drive = setup.system, setup.drive
    if start:
        check_start_file(start, loaded.sha256)
    # an impossible model "converges" to a wrong cycle: refuse it before any solve,
    # checked also where the optimizer may take it (the drive limits in force), with a
    # drive that cannot hold the kite and bounds of two parts that contradict each other
    check_drive(loaded, drive.power_model, setup.resolution.model_path, grid.kinds,
                rating_source=drive.source)
    note = _setup_note(setup, system is None, solver)
    return SweepRequest(grid, setup, note, execution.workers,
                        execution.scheduler, Path(out), claims, trust,
                        period_scan=period_scan)


def start_file(path: Path | None) -> str | None:
    """The start file of ``--start`` (a file, or an optimize folder's ``start.npz``);
    None without one.

    Raises
    ------
    InputError
        Neither such a file nor a folder holding one.
    """
    if path is None:
        return None
    file = Path(path) / START_FILE if Path(path).is_dir() else Path(path)
    if not file.is_file():
        raise InputError(path, "no start file here", column="--start",
                         expected=f"a {START_FILE} bench optimize wrote, or its output folder")
    return str(file)


def _check_ranges(solver: SolverChoice, trust: bool, period_scan: int) -> None:
    """Refuse intervals, degree and held periods out of range (:func:`make_request`)."""
    from optimize.problem.options import MAX_INTERVALS

    top = MAX_INTERVALS // 2 if trust else MAX_INTERVALS  # trust solves at 2x
    if not 2 <= solver.n_intervals <= top:
        raise InputError(None, f"--intervals {solver.n_intervals}: out of range",
                         expected=f"an integer from 2 to {top}"
                                  + (" (--trust refines to twice as many)" if trust else ""))
    if not 1 <= solver.degree <= 9:
        raise InputError(None, f"--degree {solver.degree}: out of range", expected="1 to 9")
    if not 0 <= period_scan <= MAX_PERIOD_SCAN:
        raise InputError(None, f"--period-scan {period_scan}: out of range",
                         expected=f"an integer from 0 to {MAX_PERIOD_SCAN}")


def _setup_note(setup: Setup, shipped: bool, solver: SolverChoice) -> str:
    """What the sweep flies and why: system, drive, kite limits, drivetrain, tether and
    air, thermal rating, and a mesh too coarse to trust without the result check."""
    loaded = setup.system
    note = f"system: {loaded.name} ({loaded.path}" + (", the shipped default)" if shipped
                                                      else ")")
    note += "\n" + "\n".join(setup.resolution.lines(setup.drive))
    note += "\n" + loaded.kite_limits_line()
    note += "\n" + loaded.drivetrain_line()
    note += "\n" + loaded.tether_air_line()
    note += "\n" + setup.thermal_line()
    if solver.n_intervals * solver.degree < MIN_COLLOCATION_POINTS:
        note += (f"\nmesh {mesh_label(solver.n_intervals, solver.degree)}: the result check "
                 "decides whether each optimum stands")
    return note


@dataclass(frozen=True)
class OptimizeOutcome:
    """What :func:`run_optimize` produced (the files are already written).

    Attributes
    ----------
    summary : pandas.DataFrame
        ``summary.parquet`` content.
    claims : pandas.DataFrame or None
        ``claims.csv`` content (``None`` with ``claims=False``).
    cut_ins : pandas.DataFrame
        Cut-in searches (also in the manifest).
    trust : dict
        ``{"mesh": [...], "simulation": [...]}`` records (empty without ``trust``).
    trust_lines : tuple of str
        Human-readable trust figures.
    wall_time_s : float
        Sweep wall time, cold starts included, trust checks excluded [s].
    executor : str
    files : dict
        Name -> written path.
    iterations : dict of int
        The sweep's solver iterations (:meth:`optimize.service.run.SweepResult.iterations`).
    lost : str or None
        Why the Dask cluster (or a worker of the local pool) was lost before the sweep
        ended (the scenarios it did not run failed ``"not run: ..."``); None when the sweep
        ran to its end.
    out : Path or None
        The folder written: ``request.out``, or beside it :func:`partial_folder` when the
        cluster was lost and the earlier output there converged scenarios this run lost.
    kept : str or None
        Why the earlier output in ``request.out`` was kept (:func:`earlier_is_better`).
    stopped : str
        The label of a loss the run decided itself (``"WORKER LOST"``: a solver call
        hung; ``"STOPPED"``: it gave its solver up), ``""`` for none or a lost cluster
        (:attr:`optimize.service.run.SweepResult.stopped`).
    """

    summary: Any
    claims: Any
    cut_ins: Any
    trust: dict
    trust_lines: tuple[str, ...]
    wall_time_s: float
    executor: str
    files: dict
    iterations: dict = dataclasses.field(default_factory=dict)
    lost: str | None = None
    out: Path | None = None
    kept: str | None = None
    stopped: str = ""


def run_optimize(
    request: SweepRequest,
    command_line: list[str] | None = None,
    show_progress: bool = True,
    backend: Any = None,
) -> OptimizeOutcome:
    """Plan, run and record a sweep: the library behind ``bench optimize``.

    Steps: plan the start graph (:func:`optimize.service.plan.plan_graph`); run it
    (cut-in searches included when ``request.claims``); optionally the trust
    checks (mesh check of each kind's middle-wind scenario on the executor,
    simulation check of every converged scenario); compare with the paper;
    write the folder (:func:`optimize.sweep_folder.write_sweep_folder`, docs/schemas.md §5).
    ``backend`` replaces the CasADi OCP in the solves (see
    :class:`optimize.service.builder.Backend`; the trust checks always use the OCP).
    """
    check_replaceable(request.out, "optimize", MARKERS)  # before the solves
    run = Provenance.start(command_line if command_line is not None else sys.argv)
    system, drive, options = request.setup.system, request.setup.drive, request.setup.options
    model, how = drive.power_model, request.setup.resolution
    problem = Problem.for_system(system, model, options)
    cut_in_kinds = request.cut_in_kinds
    trust: dict = {"mesh": [], "simulation": []}
    plan = plan_graph(request.grid.wind_speeds_m_s, request.grid.kinds)
    with open_executor(request.workers, request.scheduler) as handle:
        tasks = SweepTasks(problem, plan, cut_in_kinds, request.cut_in_tol_m_s, backend,
                           request.period_scan, request.grid.kinds,
                           0 if options.solver.solver == "ipopt" else GIVE_UP_AFTER)
        result = run_sweep(tasks, handle, show_progress)
        outcomes = list(result.outcomes)
        if request.trust and result.lost is None:
            trust = run_trust_checks(problem, outcomes, request.grid.wind_speeds_m_s, handle,
                                     show_progress)
    summary = outputs.summary_frame(outcomes, model.domain, domain_scales(model, system))
    parts = model_parts(problem.model.build(), model, options, system)
    cut_ins = cut_in_frame(result.cut_ins)
    claims = (evaluate_claims(summary, cut_ins, paper_system=system.paper_system,
                              system_name=system.name) if request.claims else None)
    kept = earlier_is_better(request.out, summary) if result.lost else None
    out = partial_folder(request.out) if kept else request.out
    files = write_sweep_folder(
        out, run, summary=summary, claims=claims, system=system.record(),
        trajectories=outputs.trajectories_frame(outcomes, trajectory_columns(parts)),
        carried_model=model if how.carried or not how.model_path.is_file() else None,
        manifest=sweep_manifest(request, system, options, result, summary, trust, outcomes),
        start=start_writer(problem, next((o for o in outcomes if o.name == plan[0].name),
                                         None), backend))
    return OptimizeOutcome(summary, claims, cut_ins, trust, tuple(trust.get("lines", ())),
                           result.wall_time_s, result.executor, files, result.iterations(),
                           result.lost, Path(out), kept, result.stopped)


def partial_folder(out: Path) -> Path:
    """Where a sweep cut short by a lost cluster writes when ``out`` holds a better one:
    beside it, ``<out>.partial`` (replaced by the next such run)."""
    return Path(out).with_name(Path(out).name + ".partial")


def earlier_is_better(out: Path, summary: Any) -> str | None:
    """Why the optimize output already in ``out`` must not be replaced by this sweep's
    ``summary`` (cut short by a lost cluster): it converged scenarios this one did not.
    None when there is none, it cannot be read, or this run lost nothing it has."""
    from kernel.output_folder import check_output_folder
    from optimize.sweep_folder import SUMMARY_FILE, read_summary

    try:
        check_output_folder(Path(out))
        earlier = read_summary(Path(out) / SUMMARY_FILE)
    except (InputError, OSError):
        return None  # no readable earlier output: nothing better to keep
    had = set(earlier.loc[earlier["success"].astype(bool), "scenario"])
    lost = sorted(had - set(summary.loc[summary["success"], "scenario"]))
    if not lost:
        return None
    return (f"the output already in {out} is kept: it has {len(lost)} converged scenario"
            f"{'s' * (len(lost) > 1)} this run has not ({', '.join(lost[:6])}"
            f"{', ...' if len(lost) > 6 else ''}); this run's is written to "
            f"{partial_folder(out)}")


def start_writer(problem: Problem, seed: Any, backend: Any = None) -> Any:
    """The writer of the sweep's ``start.npz`` (the seed's optimum in the stored guess's
    format, :func:`optimize.solve.starts.stored_guess.write`), or None when there is
    nothing to keep: the seed failed, its optimum stands on another mesh (the last retry's)
    or another layout than IPOPT's general one, or the solves ran on another backend."""
    o = problem.options
    if (backend is not None or seed is None or not seed.success or seed.result is None
            or o.solver.solver != "ipopt" or o.solver.transcription != "collocation"
            or seed.result.warm.n_intervals != problem.n_intervals):
        return None
    result = seed.result

    def write(path: Path) -> Path:
        return write_start(path, OcpBackend().build(problem), result, result.warm.p)

    return write


def sweep_manifest(request: SweepRequest, system: System, options: Any, result: Any,
                   summary: Any, trust: dict, outcomes: list) -> dict:
    """The optimize manifest's content after its schema and provenance header
    (docs/schemas.md §5): the request, the system and drive in force (``request.setup``),
    the options, the sweep's own record (:meth:`optimize.service.run.SweepResult.record`)
    and the result check of each scenario's final optimum (a scenario that failed its
    check is failed)."""
    drive, how = request.setup.drive, request.setup.resolution
    model = drive.power_model
    return {
        "wind_speeds_m_s": list(request.grid.wind_speeds_m_s),
        "kinds": list(request.grid.kinds),
        "scenarios": [o.name for o in result.outcomes],
        "drive_model": {  # a carried model's path and file hash: write_sweep_folder's
            "path": str(how.model_path),
            "file_sha256": (file_sha256(how.model_path)
                            if Path(how.model_path).is_file() else None),
            "model_sha256": model.sha256,
            "name": model.name,
            "note": request.model_note,
        },
        "system": system.record(),
        "drive": how.record(drive),
        "kite_limits": dataclasses.asdict(system.kite_limits()),
        "options": options.as_dict(),
        "sections": system.sections_record(),
        "bound_values": system.bound_values(),
        "converged": int(summary["success"].sum()),
        **result.record(),
        "failed": [o.name for o in outcomes if not o.success],
        "result_checks": [dataclasses.asdict(o.attempts[-1].check) for o in outcomes
                          if o.attempts and o.attempts[-1].check is not None],
        "local_optima": outputs.resolve_lines(outcomes),
        "trust": trust,
    }


def solver_options(solver: str = "ipopt", linear_solver: str | None = None,
                   stored_guess: bool = True, transcription: str = "collocation",
                   codegen: bool = False, start_file: str | None = None,
                   call_time_limit_s: float = CALL_WALL_LIMIT_S) -> Any:
    """``SolverOptions`` of ``--solver``, ``--linear-solver``, ``--no-stored-guess``,
    ``--transcription``, ``--codegen``, ``--start`` (the file, :func:`start_file`) and
    ``--call-time-limit``.

    Raises
    ------
    ValueError
        ``--linear-solver`` with fatrop, or a linear solver IPOPT cannot load here
        (:func:`optimize.solve.nlp_solver.check_linear_solver`), or an unknown transcription.
    """
    from optimize.problem.options import SolverOptions
    from optimize.solve.nlp_solver import check_linear_solver

    if linear_solver is not None and solver != "ipopt":
        raise ValueError(f"--linear-solver {linear_solver}: only IPOPT takes a linear solver, "
                         f"not --solver {solver}")
    if linear_solver is not None:
        check_linear_solver(linear_solver)
    return SolverOptions(solver=solver, linear_solver=linear_solver or "mumps",
                         stored_guess=stored_guess, transcription=transcription,
                         codegen=codegen, start_file=start_file,
                         call_time_limit_s=call_time_limit_s)


def domain_scales(model: Any, system: Any) -> tuple[float, float]:
    """Speed [rpm] and torque [N m] of distance 1 outside the validity domain.

    The drive's rating when the model states one, else the drive in force's limits
    (``system.drive``).
    """
    own = getattr(model, "drive", None)
    return tuple(float(v) for v in (own or system.drive).box())


def check_lines(summary: Any) -> list[str]:
    """One line per scenario whose optimum failed the result check (summary ``result_check``)."""
    if "result_check" not in summary.columns:
        return []
    return [f"{r.scenario} ({r.status}): {r.result_check}"
            for r in summary.itertuples(index=False) if r.result_check.startswith("failed")]


def format_summary(summary: Any, period_scan: int = 0,
                   period_bounds_s: tuple[float, float] | None = None) -> str:
    """The summary as a plain-text table (the paper's Table II analogue, and more);
    ``period_scan`` and ``period_bounds_s`` [s] (the sweep's) say why a kind was not
    period-scanned (:func:`optimize.sweep_folder.unchecked_head`)."""
    head = (
        f"{'scenario':<16} {'status':<27} {'it':>4} {'wall s':>6} {'P_elec W':>9} "
        f"{'P_mech W':>9} {'T s':>5} {'E_elec J':>9} {'rpm max':>7} {'T_q Nm':>6} "
        f"{'P_el max W':>10}"
    )
    lines = [head]
    for r in summary.itertuples(index=False):
        lines.append(
            f"{r.scenario:<16} {r.status[:27]:<27} {r.iterations:>4d} {r.total_wall_time_s:>6.1f} "
            f"{r.avg_p_elec_w:>9.0f} {r.avg_p_mech_w:>9.0f} {r.period_s:>5.2f} "
            f"{r.e_elec_j:>9.0f} {r.peak_speed_rpm:>7.0f} {r.peak_torque_nm:>6.1f} "
            f"{r.p_elec_max_w:>10.0f}"
        )
    rejected = check_lines(summary)
    if rejected:
        lines += ["", "converged, but failed the result check (physically impossible or not a "
                  "solution of the dynamics; counted as failed):", *rejected]
    finer = remesh_lines(summary)
    if finer:
        lines += ["", f"{FINER_MESH_HEAD}:", *finer]
    flagged = bound_lines(summary)
    if flagged:
        lines += ["", "optima on a bound or with a slack tether:", *flagged]
    resolved = resolve_lines_of(summary)
    if resolved:
        lines += ["", "local optima: scenarios solved again from a neighbour (off their kind's "
                  "smooth curve) or with the period held elsewhere (the period scan); the "
                  "better optimum kept:", *resolved]
    unchecked = unchecked_lines(summary)
    if unchecked:
        lines += ["", f"{unchecked_head(period_scan, period_bounds_s)}:", *unchecked]
    outside = domain_lines(summary)
    if outside:
        lines += ["", "outside the drive model's validity domain (the model extrapolates there):",
                  *outside]
    return "\n".join(lines)
