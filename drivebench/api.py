"""The stages of the ``bench`` pipeline as Python functions (docs/python_api.md).

Each function does what its ``bench`` command does, writes the same files into
its output folder (docs/schemas.md) and returns a typed result instead of a
printed table:

============ ============================== ==========================================
function     ``bench`` command              returns
============ ============================== ==========================================
:func:`ingest`   ``bench ingest``           :class:`Ingested` (``.points``)
:func:`fit`      ``bench fit``              :class:`fitting.power_model.PowerModel`
:func:`optimize` ``bench optimize``         :class:`Sweep`
:func:`aep`      ``bench aep``              :class:`AepResult`
:func:`size`     ``bench size``             :class:`SizeResult`
============ ============================== ==========================================

Bad input raises :class:`bench.errors.InputError` (the command line turns it into
exit code 2). Nothing here prints; progress bars are off unless asked for.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import pandas as pd

from bench.errors import InputError
from optimize.kinds import KINDS

#: the paper's wind grid [m/s] at the reference height
PAPER_WINDS_M_S = (4.0, 5.5, 7.0, 8.5, 10.0)


@dataclass(frozen=True)
class Ingested:
    """What :func:`ingest` did, and the store's operating points on demand.

    Attributes
    ----------
    run : bench.ingest.pipeline.IngestResult
        Sessions ingested, left unchanged, repaired or replaced; the store's manifest.
    """

    run: Any

    @cached_property
    def points(self) -> Any:
        """Every point of the store, checked as ``bench fit`` reads them
        (:class:`fitting.points.OperatingPoints`: ``.frame`` with ``speed_rpm``,
        ``torque_nm``, ``p_mech_w``, ``p_elec_w``, ``quadrant``, ...; ``.counts()``).
        Raises InputError when the store holds no point (the run says why)."""
        from fitting.points import load_points

        return load_points(self.run.store_dir)


def ingest(paths: str | Path | Sequence[str | Path], store: str | Path = "bench_store", *,
           mapping: str | Path | None = None, workers: int = 2, progress: bool = False,
           strict: bool = False, wait: bool = True, replace: bool = True,
           notify: Callable[[str], None] | None = None) -> Ingested:
    """Ingest bench campaigns or sessions into the store.

    Parameters
    ----------
    paths : path or list of paths
        Campaign or session folders (docs/schemas.md §1).
    store : path
        The store folder (created when missing; sessions already stored and
        unchanged are skipped).
    mapping : path, optional
        A mapping file for foreign column names (docs/bring_your_own_export.md).
    workers : int
        Sessions ingested in parallel.
    progress : bool
        Show progress bars.
    strict : bool
        A session that gives no operating point raises InputError.
    wait : bool
        Wait for another ingest writing the store (else raise InputError).
    replace : bool
        Replace stored sessions of the same id ingested from another folder (and say
        so through ``notify``); else raise InputError.
    notify : callable, optional
        Receives the ingest's one-line notes (repairs, replacements); silent when None.

    Returns
    -------
    Ingested
        The run's record; ``.points`` reads the store's points when asked.
    """
    from bench.ingest.pipeline import ingest as ingest_sessions

    paths = [paths] if isinstance(paths, str | Path) else list(paths)
    return Ingested(ingest_sessions(
        paths, store, mapping_path=mapping, progress=progress, workers=workers,
        strict=strict, wait=wait, replace=replace,
        notify=notify if notify is not None else (lambda line: None)))


def fit(store: str | Path = "bench_store", out: str | Path = "fit_out", *, order: int | None = 2,
        progress: bool = False, command: str = "drivebench.fit", report: Any = None,
        **options: Any) -> Any:
    """Fit the drive's power model to the store's points and write ``bench fit``'s files.

    Parameters
    ----------
    store : path
        The store of :func:`ingest`.
    out : path
        Output folder: ``power_model.json``, the efficiency map, figures (docs/schemas.md §4).
    order : int or None
        Total order of the model (2: the paper's eq. 4); None selects it.
    progress : bool
        Show progress bars.
    command : str
        The command line recorded in the outputs.
    report : callable, optional
        ``report(summary)`` receives the content of ``fit_summary.json``.
    **options
        Further fields of :class:`fitting.pipeline.FitOptions` (``folds``, ``weighting``,
        ``full_order2``, ``drive``...).

    Returns
    -------
    fitting.power_model.PowerModel
        The fitted model, as written to ``out/power_model.json``.
    """
    from bench.files import check_output_dir
    from fitting.model_file import load_power_model
    from fitting.pipeline import FitOptions, run_fit

    check_output_dir(out)  # before the fit, not after it
    summary = run_fit(store, out, FitOptions(order=order, command=command, **options),
                      progress=progress)
    if report is not None:
        report(summary)
    return load_power_model(Path(out) / "power_model.json")


@dataclass(frozen=True)
class Sweep:
    """The result of :func:`optimize`: the optimal cycles over the wind grid.

    Attributes
    ----------
    folder : Path
        The output folder (``summary.parquet``, ``trajectories.parquet``,
        ``manifest.json``, ``claims.csv``; docs/schemas.md §5).
    summary : pandas.DataFrame
        One row per scenario, failed ones included with their solver status.
    claims : pandas.DataFrame or None
        The comparison with the paper (None when not asked for).
    curves : dict
        Scenario kind -> :class:`energy.curve.PowerCurve` of its converged scenarios.
    note : str
        The system, the drive in force and the kite's limits the sweep flew with.
    trust_lines : tuple of str
        The trust checks' figures (``trust=True``).
    wall_time_s : float
        Wall time of the sweep, cold starts included, trust checks excluded [s].
    executor : str
        What it ran on (``"process pool, 2 workers"``).
    """

    folder: Path
    summary: pd.DataFrame
    claims: pd.DataFrame | None
    curves: dict
    note: str = ""
    trust_lines: tuple[str, ...] = ()
    wall_time_s: float = float("nan")
    executor: str = ""


def optimize(model: Any = None, *, winds: Sequence[float] = PAPER_WINDS_M_S,
             kinds: Sequence[str] = tuple(KINDS), system: Any = None,
             out: str | Path = "optimize_out", n_intervals: int = 40, degree: int = 4,
             workers: int = 2, scheduler: str | None = None, claims: bool = True,
             trust: bool = False, solver: str = "ipopt", linear_solver: str | None = None,
             stored_guess: bool = True, fit_default: str | Path | None = None,
             progress: bool = False, command_line: Sequence[str] = ("drivebench.optimize",),
             before_solving: Any = None) -> Sweep:
    """Optimize the pumping cycle for every scenario kind and wind speed.

    Parameters
    ----------
    model : PowerModel or path, optional
        The drive's losses (:func:`fit`'s result or a ``power_model.json``), overriding
        the system file's; default the system file's, else ``fit_default`` when it
        exists, else the paper's model (:func:`optimize.system.drive_in_force.drive_in_force`).
        A model object is written to ``out/given_power_model.json``, which the
        manifest names.
    winds : sequence of float
        Wind speeds at the reference height [m/s].
    kinds : sequence of str
        Scenario kinds (keys of :data:`optimize.kinds.KINDS`).
    system : System or path, optional
        The system file (kite, tether, winch, wind, bounds, drive rating); default the
        shipped ``highwind.toml``.
    out : path
        Output folder.
    n_intervals, degree : int
        Collocation intervals and polynomial degree of the optimal control problem.
    workers : int
        Local worker processes (ignored with ``scheduler``).
    scheduler : str, optional
        Address of a Dask scheduler.
    claims : bool
        Search the cut-in wind speeds and compare with the paper.
    trust : bool
        Also run the trust checks (mesh refinement at twice the intervals, simulation).
    solver, linear_solver, stored_guess
        NLP solver, IPOPT's linear solver, start chains from the shipped initial guess
        (:func:`optimize.command.solver_options`).
    fit_default : path, optional
        ``bench fit``'s model, used when neither ``model`` nor the system names losses.
    progress : bool
        Show a progress bar.
    command_line : sequence of str
        Recorded in the manifest.
    before_solving : callable, optional
        ``before_solving(note)``, called with :attr:`Sweep.note` once every input is
        checked, before the first solve.
    """
    from energy.curve import read_optimize_run
    from fitting.model_file import save_power_model
    from fitting.power_model import PowerModel
    from optimize.command import make_request, run_optimize

    out = Path(out)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown or not kinds:
        raise InputError(None, f"--scenarios {','.join(kinds)}: unknown scenario kinds "
                         f"{unknown or 'none given'}", expected=", ".join(KINDS))
    if isinstance(model, PowerModel):
        out.mkdir(parents=True, exist_ok=True)
        model = save_power_model(model, out / "given_power_model.json")
    elif model is not None and not isinstance(model, str | Path):
        raise InputError(None, f"model of type {type(model).__name__}",
                         expected="a PowerModel, a power_model.json path or None")
    request = make_request(
        tuple(float(w) for w in winds), tuple(kinds),
        model=Path(model) if model is not None else None, system=system,
        fit_default=Path(fit_default) if fit_default is not None else None, out=out,
        n_intervals=n_intervals, degree=degree, solver=solver, linear_solver=linear_solver,
        stored_guess=stored_guess, workers=workers, scheduler=scheduler, claims=claims,
        trust=trust)
    if before_solving is not None:
        before_solving(request.model_note)
    done = run_optimize(request, list(command_line), show_progress=progress)
    return Sweep(out, done.summary, done.claims, read_optimize_run(out).curves,
                 request.model_note, done.trust_lines, done.wall_time_s, done.executor)


@dataclass(frozen=True)
class AepResult:
    """The result of :func:`aep`.

    Attributes
    ----------
    assessment : energy.assess.Assessment
        AEP, capacity factor, bands and losses per scenario kind.
    refined : energy.refine.RefinedRun or None
        The refined curves and their solves (``refine=True``), else None.
    refine_document : dict or None
        The ``refine`` object of ``aep.json``.
    files : dict
        Name -> written path.
    """

    assessment: Any
    refined: Any
    refine_document: dict | None
    files: dict

    def table(self) -> pd.DataFrame:
        """One row per scenario kind: AEP [MWh/yr], capacity factor, 95 % band, losses."""
        return self.assessment.table()


def aep(sweep: Sweep | str | Path, site: Any, *, out: str | Path = "aep_out",
        site_note: str | None = None, site_uncertainty: Any = None, shear: Any = None,
        drive_model: str | Path | None = None, nominal_power_w: float | None = None,
        refine: bool = False, refine_tol: float | None = None, refine_max_points: int = 25,
        workers: int = 2, scheduler: str | None = None, progress: bool = False,
        command_line: Sequence[str] = ("drivebench.aep",)) -> AepResult:
    """Annual energy of the sweep's power curves at a site, and ``bench aep``'s files.

    Parameters
    ----------
    sweep : Sweep or path
        :func:`optimize`'s result or a ``bench optimize`` output folder.
    site : energy.site.Weibull or energy.site.Histogram
        Wind-speed distribution at the sweep's reference height
        (:meth:`energy.site.Weibull.from_mean`, :func:`energy.site.rayleigh`,
        :func:`energy.site.read_histogram_csv`).
    out : path
        Output folder (``aep.json``, ``power_curves.csv``, awesIO files; docs/schemas.md §7).
    site_note : str, optional
        How the site was given, for the outputs (default its description).
    site_uncertainty : energy.assess.SiteUncertainty, optional
        One-sigma errors of a Weibull site's parameters.
    shear : energy.site.Shear, optional
        The wind profile (default the sweep's system's ``[wind]``).
    drive_model : path, optional
        The power model file (default the one the sweep's manifest names).
    nominal_power_w : float, optional
        Overrides the model's nominal power for the capacity factor [W].
    refine : bool
        Solve added wind speeds where each kind's curve bends for this site
        (:mod:`energy.refine`, through the solve service); ``refine_tol``,
        ``refine_max_points``, ``workers``, ``scheduler`` and ``progress`` apply to it.
    command_line : sequence of str
        Recorded in ``aep.json``.

    Returns
    -------
    AepResult
        ``.table()`` gives one row per scenario kind.
    """
    import dataclasses
    import math

    from bench.output_folder import check_replaceable
    from energy.assess import assess, model_for_run
    from energy.curve import read_optimize_run
    from energy.outputs import AEP_KEEP, AEP_MARKERS, write_outputs
    from energy.refine import (
        DEFAULT_TOL,
        refine_document,
        refine_notes,
        refine_run,
        system_from_manifest,
    )
    from energy.site import Shear
    from fitting.model_schema import power_model_from_dict

    folder = Path(sweep.folder if isinstance(sweep, Sweep) else sweep)
    out = check_replaceable(out, "aep", AEP_MARKERS, keep=AEP_KEEP)  # before the work
    run = read_optimize_run(folder)
    if shear is None:
        system = system_from_manifest(run.manifest, folder / "manifest.json")
        shear = Shear() if system is None else Shear.from_system(system.wind)
    if site_note is None:
        site_note = f"{site.describe()} at {shear.reference_height_m:g} m"
    refined = doc = None
    if refine:
        tol = DEFAULT_TOL if refine_tol is None else refine_tol
        if not (math.isfinite(tol) and 0 < tol < 1):
            raise InputError(None, f"--refine-tol {tol}", expected="a share in (0, 1)")
        if refine_max_points < 2 or workers < 1:
            raise InputError(None, "--refine-max-points < 2 or --workers < 1",
                             expected="--refine-max-points >= 2, --workers >= 1")
        path, model_json = model_for_run(run, drive_model)
        if model_json is None:
            raise InputError(path, "power model file not found (--refine solves with it)",
                             expected="the sweep's power model, or --drive-model FILE")
        refined = refine_run(run, power_model_from_dict(model_json, path), site,
                             out / "solves", tol=tol, max_points=refine_max_points,
                             workers=workers, scheduler=scheduler, show_progress=progress)
        doc = refine_document(refined, site, tol)
    assessment = assess(refined.run if refined else run, site, site_note,
                        drive_model=drive_model, nominal_power_w=nominal_power_w,
                        site_uncertainty=site_uncertainty,
                        gradients=refined.gradients if refined else None)
    if refined is not None:
        assessment = dataclasses.replace(assessment,
                                         notes=assessment.notes + refine_notes(doc))
    files = write_outputs(assessment, refined.run if refined else run, out, list(command_line),
                          shear, refine=doc)
    return AepResult(assessment, refined, doc, files)


@dataclass(frozen=True)
class SizeResult:
    """The result of :func:`size`.

    Attributes
    ----------
    sizing : energy.sizing.SizingResult
        The candidate table, every solve record, the best and the chosen candidate.
    drive : optimize.system.drive_in_force.DriveInForce
        The reference drive (rating and losses) the candidates are scaled from.
    notes : tuple of str
        What was assumed (a rating the system file does not state).
    files : dict
        Name -> written path.
    """

    sizing: Any
    drive: Any
    notes: tuple[str, ...]
    files: dict

    @property
    def table(self) -> pd.DataFrame:
        """One row per candidate: rated torque, AEP [MWh/yr], capacity factor..."""
        return self.sizing.table

    @property
    def best(self) -> str | None:
        """The candidate with the largest electrical AEP."""
        return self.sizing.best

    @property
    def chosen(self) -> str | None:
        """The smallest candidate within the tolerance of the best AEP."""
        return self.sizing.chosen


def size(site: Any, model: Any = None, *, system: Any = None,
         fit_default: str | Path | None = None, scales: Sequence[float] = (0.5, 1.0, 2.0),
         models: Sequence[str | Path] = (), winds: Sequence[float] = PAPER_WINDS_M_S,
         out: str | Path = "size_out", site_note: str | None = None,
         rated_torque_nm: float | None = None, max_speed_rpm: float | None = None,
         overload: float | None = None, tolerance: float = 0.02, extend: int = 1,
         adaptive: bool = False,
         n_intervals: int = 40, degree: int = 4, workers: int = 2,
         scheduler: str | None = None, progress: bool = False,
         command_line: Sequence[str] = ("drivebench.size",),
         before_solving: Any = None) -> SizeResult:
    """Size the drive: electrical AEP at ``site`` of the system's drive scaled in torque.

    Parameters
    ----------
    site : energy.site.Weibull or energy.site.Histogram
        Wind-speed distribution at the reference height.
    model : PowerModel or path, optional
        The reference drive's losses; default the system file's, else ``fit_default``
        when it exists, else the paper's model
        (:func:`optimize.system.drive_in_force.drive_in_force`).
    system : System or path, optional
        The system file (its ``[drive]`` is the reference rating); default the shipped
        ``highwind.toml``.
    fit_default : path, optional
        ``bench fit``'s model, used when the system file names no losses.
    scales : sequence of float
        Torque-rating scales of the candidates (docs/schemas.md §8: the law).
    models : sequence of paths
        Further candidates: power-model files with their own ``drive`` rating.
    winds : sequence of float
        Wind speeds [m/s] solved per candidate (at least two).
    out : path
        Output folder (``sizing.json``, ``sizing.csv``, the resumable ``solves/``).
    rated_torque_nm, max_speed_rpm, overload : float, optional
        Override the reference rating's continuous torque [N m], speed limit [rpm],
        peak-over-continuous torque [-].
    tolerance : float
        The chosen drive is the smallest within this share of the best AEP.
    extend : int
        While the best drive is the largest or smallest scale, add one beyond it and size
        again, up to this many times (:func:`energy.sizing.size_extending`).
    adaptive : bool
        Refine each candidate's grid where its curve bends for the site.
    n_intervals, degree, workers, scheduler, progress
        As for :func:`optimize`.
    before_solving : callable, optional
        ``before_solving(drive, n_candidates)``, called once the candidates are made.
    """
    from bench.output_folder import check_replaceable
    from energy.candidates import build_candidates
    from energy.sizing import run_sizing, size_extending
    from energy.sizing_files import SIZE_KEEP, SIZE_MARKERS, edge_note, grid_hours, write_sizing
    from fitting.power_model import PowerModel
    from optimize.system.drive_in_force import drive_in_force
    from optimize.system.system import System
    from optimize.system.system_file import load_system

    if len(winds) < 2:
        raise InputError(None, f"--wind-grid {','.join(f'{w:g}' for w in winds)}: one wind "
                         "speed gives no AEP curve to integrate",
                         expected="at least two wind speeds")
    if not 0 <= tolerance < 1:
        raise InputError(None, f"--tolerance {tolerance}", expected="a share in [0, 1)")
    if extend < 0:
        raise InputError(None, f"--extend {extend}", expected="an integer >= 0")
    check_replaceable(out, "size", SIZE_MARKERS, keep=SIZE_KEEP)  # before the work
    system = system if isinstance(system, System) else load_system(system)
    if isinstance(model, PowerModel):
        drive = drive_in_force(system, model=model)
    else:
        drive = drive_in_force(system, model, fit_default)
    candidates, notes = build_candidates(drive, tuple(scales), tuple(models), rated_torque_nm,
                                         max_speed_rpm, overload)
    if before_solving is not None:
        before_solving(drive, len(candidates))
    out = Path(out)
    result, edge, added = size_extending(
        lambda sc: build_candidates(drive, sc, tuple(models), rated_torque_nm, max_speed_rpm,
                                    overload)[0],
        tuple(scales), extend,
        lambda cands: run_sizing(cands, tuple(float(w) for w in winds), site, out, n_intervals,
                                 degree, workers=workers, scheduler=scheduler,
                                 show_progress=progress, tolerance=tolerance,
                                 adaptive=adaptive, system=system))
    edge_doc = {"best_at": edge, "added_scales": added,
                "note": edge_note(edge, result.best, added)}
    notes = [*notes, grid_hours(site, tuple(winds))["note"],
             *([edge_doc["note"]] if edge_doc["note"] else [])]
    files = write_sizing(out, result, site=site, site_note=site_note or site.describe(),
                         drive=drive, system=system, winds=tuple(winds), adaptive=adaptive,
                         tolerance=tolerance, notes=notes, command_line=list(command_line),
                         edge=edge_doc)
    return SizeResult(result, drive, tuple(notes), files)
