"""The whole ``bench optimize`` command as a library call: :func:`run_optimize`.

Plan the chains (:mod:`optimize.sweep.plan`), run them on the solve service
(:mod:`optimize.service`, on :mod:`optimize.sweep.executors`), the trust
checks (:mod:`optimize.sweep.trust`), the paper comparison
(:mod:`optimize.analysis.claims`) and the files (:mod:`optimize.sweep.outputs`).
This module sits above the solver and the analysis; nothing in them imports it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bench.errors import InputError
from bench.files import check_output_dir, file_sha256, write_csv, write_json, write_parquet
from bench.output_folder import check_replaceable, output_folder
from bench.versions import package_versions
from optimize.analysis.claims import cut_in_frame, evaluate_claims
from optimize.analysis.result_check import MIN_COLLOCATION_POINTS, mesh_label
from optimize.kinds import KINDS
from optimize.service import Problem, make_tasks, run_sweep
from optimize.sweep import outputs
from optimize.sweep.executors import open_executor
from optimize.sweep.plan import plan_chains
from optimize.sweep.result_checks import check_outcomes
from optimize.sweep.trust import run_trust_checks
from optimize.system.drive_in_force import DriveInForce, drive_in_force
from optimize.system.plausibility import check_drive_holds_kite
from optimize.system.system import System
from optimize.system.system_file import load_system

#: files by which an optimize output folder written before run ids is known
OPTIMIZE_MARKERS = ("summary.parquet", "manifest.json")
#: a model given to the Python API, written beside the outputs before the sweep and
#: named by its manifest: kept from the folder, not part of the run
OPTIMIZE_KEEP = ("given_power_model.json",)


@dataclass(frozen=True)
class SweepRequest:
    """Everything ``bench optimize`` was asked to do (see :func:`run_optimize`).

    Attributes
    ----------
    winds : tuple of float
        Wind speeds [m/s].
    kinds : tuple of str
        Scenario kinds.
    drive_model : Any
        ``fitting.power_model.PowerModel``.
    drive_model_path : Path
        Where it was read from.
    model_note : str
        One line saying which model is used and why.
    options : Any
        ``optimize.problem.options.OcpOptions``.
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
    system : System or None
        The system (``--system``); ``None`` is the shipped ``highwind.toml``. Its
        bounds and drive limits replace those of ``options``.
    drive : optimize.system.drive_in_force.DriveInForce or None
        The drive in force (rating, losses at that rating); ``None``: the system's
        ``[drive]`` rating with ``drive_model``'s losses.
    """

    winds: tuple[float, ...]
    kinds: tuple[str, ...]
    drive_model: Any
    drive_model_path: Path
    model_note: str
    options: Any
    workers: int = 2
    scheduler: str | None = None
    out: Path = Path("optimize_out")
    claims: bool = True
    trust: bool = False
    cut_in_tol_m_s: float = 0.05
    system: System | None = None
    drive: DriveInForce | None = None


def make_request(winds: tuple[float, ...], kinds: tuple[str, ...], *,
                 model: Path | None = None, system: Path | System | None = None,
                 fit_default: Path | None = None, out: Path = Path("optimize_out"),
                 n_intervals: int = 40, degree: int = 4, solver: str = "ipopt",
                 linear_solver: str | None = None, stored_guess: bool = True,
                 workers: int = 2, scheduler: str | None = None, claims: bool = True,
                 trust: bool = False) -> SweepRequest:
    """The request of a sweep, every input checked before any solve.

    Parameters
    ----------
    winds, kinds
        Wind speeds [m/s] and scenario kinds (:func:`optimize.sweep.plan.parse_wind_grid`,
        :func:`optimize.sweep.plan.parse_kinds`).
    model : Path, optional
        The drive's losses (``--drive-model``), overriding the system file's.
    system : Path or System, optional
        The system (``--system``); default the shipped ``highwind.toml``.
    fit_default : Path, optional
        ``bench fit``'s model, used when it exists and neither ``model`` nor the system
        file names the losses (:func:`optimize.system.drive_in_force.drive_in_force`).
    out : Path
        Output folder (must be a folder or absent).
    n_intervals, degree : int
        Collocation intervals (2 to :data:`optimize.problem.options.MAX_INTERVALS`, half
        that with ``trust``, which refines to twice as many) and Radau degree (1 to 9).
    solver, linear_solver, stored_guess
        :func:`solver_options`.
    workers, scheduler, claims, trust
        As :class:`SweepRequest`.

    Raises
    ------
    InputError
        Any input out of range or unreadable; a drive model that is physically
        impossible or a drive that cannot hold the kite.
    """
    from fitting.model_check import check_physics
    from optimize.problem.options import MAX_INTERVALS, Discretization, OcpOptions

    top = MAX_INTERVALS // 2 if trust else MAX_INTERVALS  # trust solves at 2x
    if not 2 <= n_intervals <= top:
        raise InputError(None, f"--intervals {n_intervals}: out of range",
                         expected=f"an integer from 2 to {top}"
                                  + (" (--trust refines to twice as many)" if trust else ""))
    if not 1 <= degree <= 9:
        raise InputError(None, f"--degree {degree}: out of range", expected="1 to 9")
    check_output_dir(out)
    loaded = system if isinstance(system, System) else load_system(system)
    drive = drive_in_force(loaded, model, fit_default)
    note = f"system: {loaded.name} ({loaded.path}" + (
        ", the shipped default)" if system is None else ")")
    note += "\n" + "\n".join(drive.lines())
    try:
        options = OcpOptions(Discretization(n_intervals=n_intervals, degree=degree),
                             solver=solver_options(solver, linear_solver, stored_guess))
    except ValueError as exc:
        raise InputError(None, f"OCP options: {exc}") from exc
    options = loaded.ocp_options(options, drive.rating)
    # an impossible model "converges" to a wrong cycle: refuse it before any solve,
    # checked also where the optimizer may take it (the drive limits in force)
    check_physics(drive.model, drive.model_path,
                  limits=(options.limits.max_speed_rpm, options.limits.max_torque_nm))
    check_drive_holds_kite(loaded, drive.rating.max_torque_nm,
                           drive.rating.source or "the drive in force")
    note += "\n" + loaded.kite_limits().describe()
    note += "\n" + loaded.drivetrain_line()
    if n_intervals * degree < MIN_COLLOCATION_POINTS:
        note += (f"\nmesh {mesh_label(n_intervals, degree)}: the result check decides whether "
                 "each optimum stands")
    return SweepRequest(tuple(winds), tuple(kinds), drive.model, drive.model_path, note,
                        options, workers, scheduler, Path(out), claims, trust,
                        system=loaded, drive=drive)


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
    """

    summary: Any
    claims: Any
    cut_ins: Any
    trust: dict
    trust_lines: tuple[str, ...]
    wall_time_s: float
    executor: str
    files: dict


def run_optimize(
    request: SweepRequest,
    command_line: list[str] | None = None,
    show_progress: bool = True,
    backend: Any = None,
) -> OptimizeOutcome:
    """Plan, run and record a sweep: the library behind ``bench optimize``.

    Steps: plan warm-start chains for the executor's worker count; run them
    (cut-in searches included when ``request.claims``); optionally the trust
    checks (mesh check of each kind's middle-wind scenario on the executor,
    simulation check of every converged scenario); compare with the paper;
    write ``summary.parquet``, ``trajectories.parquet``, ``claims.csv`` and
    ``manifest.json`` (docs/schemas.md §5) into ``request.out``, all or none
    (:mod:`bench.output_folder`).
    ``backend`` replaces the CasADi OCP in the chains (see
    :class:`optimize.service.builder.Backend`; the trust checks always use the OCP).
    """
    import dataclasses
    import datetime
    import sys


    check_replaceable(request.out, "optimize", OPTIMIZE_MARKERS,
                      keep=OPTIMIZE_KEEP)  # before the solves
    system = request.system if request.system is not None else load_system()
    drive = request.drive or drive_in_force(system, request.drive_model_path,
                                            model=request.drive_model)
    model = drive.model
    options = system.ocp_options(request.options, drive.rating)
    problem = Problem.for_system(system, model, options)
    cut_in_kinds = (tuple(k for k in request.kinds if KINDS[k].drive_limits)
                    if request.claims else ())
    trust: dict = {"mesh": [], "simulation": []}
    with open_executor(request.workers, request.scheduler) as handle:
        chains = plan_chains(request.winds, request.kinds, handle.n_workers)
        tasks = make_tasks(chains, problem, cut_in_kinds, request.cut_in_tol_m_s, backend)
        result = run_sweep(tasks, handle, show_progress)
        outcomes, checks = (check_outcomes(problem, result.outcomes) if backend is None
                            else (list(result.outcomes), []))
        if request.trust:
            trust = run_trust_checks(problem, outcomes, request.winds, handle)
    summary = outputs.summary_frame(outcomes, model.domain, domain_scales(model, options))
    cut_ins = cut_in_frame(result.cut_ins)
    claims = (evaluate_claims(summary, cut_ins, paper_system=system.paper_system,
                              system_name=system.name) if request.claims else None)

    with output_folder(request.out, "optimize", OPTIMIZE_MARKERS,
                       keep=OPTIMIZE_KEEP) as stage:  # all or none
        system_meta = outputs.system_metadata(system.record())
        files = {
            "summary": write_parquet(stage / "summary.parquet", summary,
                                     descriptions=outputs.SUMMARY_COLUMNS, metadata=system_meta),
            "trajectories": write_parquet(stage / "trajectories.parquet",
                                          outputs.trajectories_frame(outcomes),
                                          metadata=system_meta),
        }
        model_path = request.drive_model_path
        if drive.carried:  # the losses the sweep flew with, for bench aep (bands, refine)
            from fitting.model_file import save_power_model

            model_path = files["power_model"] = save_power_model(model,
                                                                 stage / "power_model.json")
        if claims is not None:  # else no stale comparison is left: the folder is replaced
            files["claims"] = write_csv(stage / "claims.csv", claims)
        manifest = {
            "schema": outputs.SCHEMA_NAME,
            "schema_version": outputs.SCHEMA_VERSION,
            "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "command_line": list(command_line if command_line is not None else sys.argv),
            "package_versions": package_versions(),
            "wind_speeds_m_s": list(request.winds),
            "kinds": list(request.kinds),
            "scenarios": [o.name for o in outcomes],
            "drive_model": {
                "path": str(stage / "power_model.json" if drive.carried
                            else model_path),
                "file_sha256": file_sha256(model_path),
                "model_sha256": model.sha256,
                "name": model.name,
                "note": request.model_note,
            },
            "system": system.record(),
            "drive_limits": drive.rating.to_dict(),
            "drive": drive.record(),
            "kite_limits": dataclasses.asdict(system.kite_limits()),
            "options": options.as_dict(),
            "executor": result.executor,
            "wall_time_s": result.wall_time_s,
            "converged": int(summary["success"].sum()),
            "failed": [o.name for o in outcomes if not o.success],
            "result_checks": [dataclasses.asdict(c) for c in checks],
            "chains": [
                {
                    "chain": c.chain,
                    "worker": c.worker,
                    "build_time_s": c.build_time_s,
                    "scenarios": [o.name for o in c.outcomes],
                }
                for c in result.chains
            ],
            "local_optima": outputs.resolve_lines(outcomes),
            "cut_in": [dataclasses.asdict(c) for c in result.cut_ins],
            "trust": trust,
            "files": {k: Path(v).name for k, v in files.items()},
        }
        files["manifest"] = write_json(stage / "manifest.json", manifest)
    files = {k: request.out / Path(v).relative_to(stage) for k, v in files.items()}
    return OptimizeOutcome(
        summary,
        claims,
        cut_ins,
        trust,
        tuple(trust.get("lines", ())),
        result.wall_time_s,
        result.executor,
        files,
    )


def solver_options(solver: str = "ipopt", linear_solver: str | None = None,
                   stored_guess: bool = True) -> Any:
    """``SolverOptions`` of ``--solver``, ``--linear-solver`` and ``--no-stored-guess``.

    Raises
    ------
    ValueError
        ``--linear-solver`` with fatrop, or a linear solver IPOPT cannot load here
        (:func:`optimize.solve.backend.check_linear_solver`).
    """
    from optimize.problem.options import SolverOptions
    from optimize.solve.backend import check_linear_solver

    if linear_solver is not None and solver != "ipopt":
        raise ValueError(f"--linear-solver {linear_solver}: only IPOPT takes a linear solver, "
                         f"not --solver {solver}")
    if linear_solver is not None:
        check_linear_solver(linear_solver)
    return SolverOptions(solver=solver, linear_solver=linear_solver or "mumps",
                         stored_guess=stored_guess)


def domain_scales(model: Any, options: Any) -> tuple[float, float]:
    """Speed [rpm] and torque [N m] of distance 1 outside the validity domain.

    The drive's rating when the model states one, else the OCP's drive limits.
    """
    drive = getattr(model, "drive", None) or {}
    return (float(drive.get("max_speed_rpm", options.limits.max_speed_rpm)),
            float(drive.get("max_torque_nm", options.limits.max_torque_nm)))


def domain_lines(summary: Any) -> list[str]:
    """One line per converged scenario whose cycle leaves the model's validity domain."""
    lines = []
    for r in summary.itertuples(index=False):
        frac = r.outside_domain_time_frac
        if r.success and np.isfinite(frac) and frac > 0:
            lines.append(
                f"{r.scenario}: {100 * frac:.1f} % of the cycle time outside the drive model's "
                f"validity domain; worst at {r.outside_worst_speed_rpm:.0f} rpm, "
                f"{r.outside_worst_torque_nm:.1f} N m (distance {r.outside_worst_distance:.3f} "
                "of the drive rating)")
    return lines


def bound_lines(summary: Any) -> list[str]:
    """One line per converged scenario on a bound or with a slack tether."""
    lines = []
    for r in summary.itertuples(index=False):
        slack = r.slack_fraction
        if r.success and (r.active_bounds or (np.isfinite(slack) and slack > 0)):
            note = (" BOUND-LIMITED: the optimum is the bound's, not the kite's"
                    if r.bound_limited else "")
            lines.append(f"{r.scenario}: on {r.active_bounds or 'no bound'}; slack tether "
                         f"{100 * slack:.1f} % of the cycle{note}")
    return lines


def check_lines(summary: Any) -> list[str]:
    """One line per scenario whose optimum failed the result check (summary ``result_check``)."""
    if "result_check" not in summary.columns:
        return []
    return [f"{r.scenario} ({r.status}): {r.result_check}"
            for r in summary.itertuples(index=False) if r.result_check.startswith("failed")]


def resolve_lines_of(summary: Any) -> list[str]:
    """One line per scenario re-solved from a neighbour (summary ``resolved_from``)."""
    if "resolved_from" not in summary.columns:
        return []
    lines = []
    for r in summary.itertuples(index=False):
        if r.resolved_from:
            gain = (f"better by {r.resolve_gain_w:.1f} W, kept" if r.resolve_gain_w > 0
                    else "no better optimum found")
            lines.append(f"{r.scenario}: re-solved from {r.resolved_from}: {gain}")
    return lines


def format_summary(summary: Any) -> str:
    """The summary as a plain-text table (the paper's Table II analogue, and more)."""
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
    flagged = bound_lines(summary)
    if flagged:
        lines += ["", "optima on a bound or with a slack tether:", *flagged]
    resolved = resolve_lines_of(summary)
    if resolved:
        lines += ["", "local optima: scenarios off their kind's smooth curve, solved again from "
                  "a neighbour (the better optimum kept):", *resolved]
    outside = domain_lines(summary)
    if outside:
        lines += ["", "outside the drive model's validity domain (the model extrapolates there):",
                  *outside]
    return "\n".join(lines)
