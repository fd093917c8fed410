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
:func:`cycle_export` ``bench cycle export`` :class:`cycle.export.Exported`
:func:`cycle_verify` ``bench cycle verify`` :class:`cycle.verify_command.Verified`
============ ============================== ==========================================

Bad input raises :class:`kernel.errors.InputError` (the command line turns it into
exit code 2). Nothing here prints; progress bars are off unless asked for.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import pandas as pd

from cycle.export import DEFAULT_EXPORT, ExportOptions
from energy.aep_command import RefineOptions, SiteSpec
from energy.size_command import DEFAULT_SIZING, SYSTEM_RATING, RatingOverrides, SizingGrid
from fitting.power_model import PowerModel
from kernel.display import html_view, text_view
from kernel.errors import InputError
from optimize.door import (
    DEFAULT_SOLVER,
    LOCAL_POOL,
    PAPER_GRID,
    Execution,
    SolverChoice,
    WindGrid,
)


@dataclass(frozen=True)
class Ingested:
    """What :func:`ingest` did, and the store's operating points on demand.

    Attributes
    ----------
    run : bench.ingest.pipeline.IngestResult
        Sessions ingested, left unchanged, repaired or replaced; the store's manifest.
    """

    run: Any

    def _view_rows(self) -> list[tuple[str, object]]:
        r = self.run
        sessions = (r.manifest or {}).get("sessions") or {}
        return [("store", r.store_dir), ("sessions in the store", len(sessions)),
                ("ingested", ", ".join(r.ingested) or "none"),
                ("unchanged (skipped)", ", ".join(r.unchanged) or "none"),
                ("repaired", ", ".join(r.repaired) or "none"),
                ("replaced", ", ".join(r.replaced) or "none")]

    def __repr__(self) -> str:
        return text_view("Ingested (.run; .points reads the store's points)",
                         self._view_rows())

    def _repr_html_(self) -> str:
        return html_view("Ingested", self._view_rows())

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
           notify: Callable[[str], None] | None = None,
           command_line: Sequence[str] = ("drivebench.ingest",)) -> Ingested:
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
    command_line : sequence of str
        Recorded in the store manifest's provenance header.

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
        notify=notify if notify is not None else (lambda line: None),
        command_line=tuple(command_line)))


def fit(store: str | Path = "bench_store", out: str | Path = "fit_out", *, order: int | None = 2,
        progress: bool = False, command_line: Sequence[str] = ("drivebench.fit",),
        report: Any = None,
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
    command_line : sequence of str
        The command line recorded in the outputs' provenance.
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
    from fitting.model_file import load_power_model
    from fitting.pipeline import FitOptions, run_fit

    summary = run_fit(store, out, FitOptions(order=order, command_line=tuple(command_line),
                                                  **options),
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

    def _view_rows(self) -> list[tuple[str, object]]:
        s = self.summary
        ok = s["success"].astype(bool)
        rows = [("folder", self.folder),
                ("scenarios", f"{int(ok.sum())} of {len(s)} converged"),
                ("kinds", ", ".join(dict.fromkeys(s["kind"].astype(str)))),
                ("wind speeds [m/s]", ", ".join(f"{w:g}" for w in
                                                sorted(set(s["wind_speed_m_s"].astype(float))))),
                ("failed", ", ".join(f"{r.scenario} ({r.status})" for r in
                                     s[~ok].itertuples(index=False)) or "none")]
        if self.claims is not None and len(self.claims):
            counts = self.claims["verdict"].value_counts()
            rows.append(("paper's statements", ", ".join(f"{n} {v}" for v, n in counts.items())))
        rows += [("ran on", f"{self.executor}, {self.wall_time_s:.1f} s"),
                 ("system and drive", self.note)]
        return rows

    @cached_property
    def cycle_of(self) -> dict:
        """The converged scenarios' cycles by scenario name
        (:class:`optimize.cycles.Cycle`: ``.points``, ``.period_s``, ``.average(column)``,
        ``.energy_j(column)``, ``.metrics()``, ``.closed()``, ``.plot(ax)``), read from
        ``trajectories.parquet`` on first use."""
        from optimize.door import sweep_cycles
        from optimize.sweep_folder import read_trajectories

        return sweep_cycles(self.summary, read_trajectories(self.folder))

    def cycles(self, wind_speed_m_s: float) -> dict[str, pd.DataFrame]:
        """The converged cycles at one wind speed: scenario kind -> the closed cycle
        (``time_s`` from 0 to the period [s], ``speed_rpm``, ``torque_nm``, ``p_elec_w``,
        ``p_mech_w``, ...: ``trajectories.parquet``'s columns, docs/schemas.md §5)."""
        return {c.kind: c.closed() for c in self.cycle_of.values()
                if abs(c.wind_speed_m_s - wind_speed_m_s) < 1e-9}

    def plot_cycle(self, scenario: str, ax: Any = None) -> Any:
        """Shaft and grid power over one cycle of ``scenario`` (:func:`plot_cycle`)."""
        if scenario not in self.cycle_of:
            raise InputError(self.folder / "trajectories.parquet",
                             f"no cycle of scenario {scenario!r}",
                             expected="a converged scenario of .summary")
        return self.cycle_of[scenario].plot(ax)

    def __repr__(self) -> str:
        return text_view("Sweep (.summary, .curves, .claims)", self._view_rows())

    def _repr_html_(self) -> str:
        cols = [c for c in ("scenario", "status", "avg_p_elec_w", "avg_p_mech_w", "period_s")
                if c in self.summary.columns]
        return html_view("Sweep", self._view_rows(), [("summary", self.summary[cols])])


def optimize(drive_model: Any = None, *, grid: WindGrid = PAPER_GRID, system: Any = None,
             solver: SolverChoice = DEFAULT_SOLVER, execution: Execution = LOCAL_POOL,
             out: str | Path = "optimize_out", claims: bool = True, trust: bool = False,
             period_scan: int = 0, fit_default: str | Path | None = None,
             command_line: Sequence[str] = ("drivebench.optimize",),
             before_solving: Callable[[str], None] | None = None) -> Sweep:
    """Optimize the pumping cycle for every scenario kind and wind speed.

    Parameters
    ----------
    drive_model : PowerModel or path, optional
        The drive's losses (:func:`fit`'s result or a ``power_model.json``), overriding
        the system file's; default the system file's, else ``fit_default`` when it
        exists, else the paper's model (:func:`optimize.system.drive_in_force.drive_in_force`).
        A model object is written into ``out`` with the results (``power_model.json``,
        which the manifest names).
    grid : WindGrid
        Wind speeds at the reference height [m/s] and scenario kinds.
    system : System or path, optional
        The system file (kite, tether, winch, wind, bounds, drive rating); default the
        shipped ``highwind.toml``.
    solver : SolverChoice
        Collocation intervals and degree, NLP and linear solver, stored initial guess.
    execution : Execution
        Worker processes or a Dask scheduler; a progress bar.
    out : path
        Output folder.
    claims : bool
        Search the cut-in wind speeds and compare with the paper.
    trust : bool
        Also run the trust checks (mesh refinement at twice the intervals, simulation).
    period_scan : int
        Solve each converged scenario again with its period held at this many other values
        (from half to twice its own, within the period bounds), then free, and keep the
        best optimum (``bench optimize --period-scan N``; 0: no scan).
    fit_default : path, optional
        ``bench fit``'s model, used when neither ``drive_model`` nor the system names losses.
    command_line : sequence of str
        Recorded in the manifest's provenance header.
    before_solving : callable, optional
        ``before_solving(note)``, called with :attr:`Sweep.note` once every input is
        checked, before the first solve.
    """
    from energy.curve import read_optimize_run
    from optimize.door import make_request, run_optimize

    if drive_model is not None and not isinstance(drive_model, str | Path | PowerModel):
        raise InputError(None, f"drive_model of type {type(drive_model).__name__}",
                         expected="a PowerModel, a power_model.json path or None")
    request = make_request(grid, solver, drive_model=drive_model, system=system, out=Path(out),
                           fit_default=Path(fit_default) if fit_default is not None else None,
                           execution=execution, claims=claims, trust=trust,
                           period_scan=period_scan)
    if before_solving is not None:
        before_solving(request.model_note)
    done = run_optimize(request, list(command_line), show_progress=execution.progress)
    return Sweep(Path(out), done.summary, done.claims, read_optimize_run(out).curves,
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

    def _view_rows(self) -> list[tuple[str, object]]:
        rows: list[tuple[str, object]] = [("site", self.assessment.site_note)]
        for r in self.table().itertuples(index=False):
            band = ("" if r.ci95_aep_elec_low_mwh is None or pd.isna(r.ci95_aep_elec_low_mwh)
                    else f" (95 %: {r.ci95_aep_elec_low_mwh:.3g} to "
                         f"{r.ci95_aep_elec_high_mwh:.3g})")
            rows.append((f"AEP {r.kind}", f"electrical {r.aep_elec_mwh:.3g} MWh/yr{band}, "
                                          f"mechanical {r.aep_mech_mwh:.3g} MWh/yr"))
        rows.append(("refined", "yes" if self.refined is not None else "no"))
        rows.append(("files", ", ".join(str(p) for p in self.files.values())))
        return rows

    def plot_power_curves(self, ax: Any = None) -> Any:
        """The power curves with their 95 % bands (:func:`plot_power_curves`)."""
        from energy.plots import plot_power_curves

        return plot_power_curves(self.assessment.curves, ax)

    def plot_aep(self, ax: Any = None) -> Any:
        """AEP per scenario kind with its band (:func:`plot_aep`)."""
        from energy.plots import plot_aep

        return plot_aep(self.table(), ax)

    def __repr__(self) -> str:
        return text_view("AepResult (.table(), .assessment)", self._view_rows())

    def _repr_html_(self) -> str:
        return html_view("AepResult", self._view_rows(), [("table()", self.table())])


def aep(sweep: Sweep | str | Path, site: Any, *, out: str | Path = "aep_out",
        drive_model: str | Path | None = None, nominal_power_w: float | None = None,
        refine: RefineOptions | None = None, execution: Execution = LOCAL_POOL,
        command_line: Sequence[str] = ("drivebench.aep",)) -> AepResult:
    """Annual energy of the sweep's power curves at a site, and ``bench aep``'s files
    (:func:`energy.aep_command.run_aep`).

    Parameters
    ----------
    sweep : Sweep or path
        :func:`optimize`'s result or a ``bench optimize`` output folder.
    site : SiteSpec, or energy.site.Weibull or energy.site.Histogram
        The site: a distribution at the sweep's reference height
        (:meth:`energy.site.Weibull.from_mean`, :func:`energy.site.rayleigh`,
        :func:`energy.site.read_histogram_csv`), or a :class:`SiteSpec` with its note,
        parameter uncertainty and wind profile.
    out : path
        Output folder (``aep.json``, ``power_curves.csv``, awesIO files; docs/schemas.md §7).
    drive_model : path, optional
        The power model file (default the one the sweep's manifest names).
    nominal_power_w : float, optional
        Overrides the model's nominal power for the capacity factor [W].
    refine : RefineOptions, optional
        Solve added wind speeds where each kind's curve bends for this site
        (:mod:`energy.refine`, through the solve service, on ``execution``).
    command_line : sequence of str
        Recorded in ``aep.json``'s provenance header.

    Returns
    -------
    AepResult
        ``.table()`` gives one row per scenario kind.
    """
    from energy.aep_command import run_aep

    folder = sweep.folder if isinstance(sweep, Sweep) else sweep
    done = run_aep(folder, site if isinstance(site, SiteSpec) else SiteSpec(site), out=out,
                   drive_model=drive_model, nominal_power_w=nominal_power_w, refine=refine,
                   execution=execution, command_line=command_line)
    return AepResult(done.assessment, done.refined, done.refine_document, done.files)


@dataclass(frozen=True)
class SizeResult:
    """The result of :func:`size`.

    Attributes
    ----------
    sizing : energy.sizing.SizingResult
        The candidate table, every solve record, the best and the chosen candidate.
    drive : kernel.drive.Drive
        The reference drive (rating, envelope and losses: its ``power_model``) the
        candidates are scaled from.
    notes : tuple of str
        What was assumed (a rating the system file does not state).
    files : dict
        Name -> written path.
    decision : dict
        Whether the choice holds for the site (:func:`energy.decision.decision`: ``holds``,
        ``line``, the grid that covers the site).
    """

    sizing: Any
    drive: Any
    notes: tuple[str, ...]
    files: dict
    decision: dict = field(default_factory=dict)

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

    def _view_rows(self) -> list[tuple[str, object]]:
        t = self.table
        aep = ", ".join(f"{r.candidate} {r.aep_elec_mwh:.3g}" if pd.notna(r.aep_elec_mwh)
                        else f"{r.candidate} failed" for r in t.itertuples(index=False))
        return [("decision", self.decision.get("line") or
                 f"{self.chosen} (smallest within tolerance of the best, {self.best})"),
                ("electrical AEP [MWh/yr]", aep),
                ("solves", f"{self.sizing.n_solved} solved, {self.sizing.n_cached} loaded, "
                           f"{self.sizing.wall_time_s:.1f} s"),
                *((f"note {k + 1}", n) for k, n in enumerate(self.notes))]

    def __repr__(self) -> str:
        return text_view("SizeResult (.table, .chosen, .best)", self._view_rows())

    def _repr_html_(self) -> str:
        cols = [c for c in ("candidate", "rated_torque_nm", "aep_elec_mwh", "aep_share_of_best",
                            "n_converged", "n_winds") if c in self.table.columns]
        return html_view("SizeResult", self._view_rows(), [("table", self.table[cols])])


def size(site: Any, drive_model: Any = None, *, system: Any = None,
         fit_default: str | Path | None = None, grid: SizingGrid = DEFAULT_SIZING,
         rating: RatingOverrides = SYSTEM_RATING, solver: SolverChoice = DEFAULT_SOLVER,
         execution: Execution = LOCAL_POOL, out: str | Path = "size_out",
         site_note: str | None = None, command_line: Sequence[str] = ("drivebench.size",),
         before_solving: Callable[[Any, int, tuple], None] | None = None) -> SizeResult:
    """Size the drive: electrical AEP at ``site`` of the system's drive scaled in torque
    (:func:`energy.size_command.run_size`; the parameters are its own).

    Parameters
    ----------
    site : energy.site.Weibull or energy.site.Histogram
        Wind-speed distribution at the reference height.
    drive_model : PowerModel or path, optional
        The reference drive's losses; default the system file's, else ``fit_default``
        when it exists, else the paper's model
        (:func:`optimize.system.drive_in_force.drive_in_force`).
    system : System or path, optional
        The system file (its ``[drive]`` is the reference rating); default the shipped
        ``highwind.toml``.
    fit_default : path, optional
        ``bench fit``'s model, used when the system file names no losses.
    grid : SizingGrid
        Torque-rating scales, further candidate models, wind speeds, the choice's tolerance,
        scales added beyond the edge, adaptive grids.
    rating : RatingOverrides
        The reference rating's continuous torque, speed limit and torque limit, when not
        the system's (x1 is then not the drive :func:`optimize` flies).
    solver, execution : SolverChoice, Execution
        As for :func:`optimize` (``solver``: its ``n_intervals`` and ``degree``).
    out : path
        Output folder (``sizing.json``, ``sizing.csv``, the resumable ``solves/``).
    before_solving : callable, optional
        ``before_solving(setup, n_candidates, wind_speeds_m_s)`` (``setup``: the system,
        the reference drive and how it was resolved), called once the candidates and the
        wind grid are made.
    """
    from energy.size_command import run_size

    done = run_size(site, drive_model, system=system, fit_default=fit_default, grid=grid,
                    rating=rating, solver=solver, execution=execution, out=out,
                    site_note=site_note, command_line=command_line,
                    before_solving=before_solving)
    return SizeResult(done.sizing, done.drive, done.notes, done.files, done.decision)


def cycle_export(optimize: str | Path, scenario: str, out: str | Path = "profile.csv", *,
                 options: ExportOptions = DEFAULT_EXPORT,
                 bench_session: str | Path | None = None,
                 command_line: Sequence[str] = ("drivebench.cycle_export",)) -> Any:
    """Write a converged scenario of a sweep as a drive profile a bench runs.

    Parameters
    ----------
    optimize : path
        An optimize output folder (:func:`optimize`'s ``out``).
    scenario : str
        A converged scenario of it, e.g. ``"elec-lim-7.0"``.
    out : path
        The profile CSV (docs/schemas.md §10); its two plain tables go beside it.
    options : ExportOptions
        Cycles, set-point rate, standstill, ramp and the bench frame (:class:`BenchFrame`);
        default 10 cycles at 100 Hz in the drum frame.
    bench_session : path, optional
        A session folder of the bench's campaign whose drive rating and stated sensor
        ranges are limits too (its frame is ``options.frame``'s business).
    command_line : sequence of str
        Recorded in the profile's provenance header.

    Returns
    -------
    cycle.export.Exported
        ``.files``, ``.profile`` (header and columns), ``.e_mech_cycles_j``.
    """
    from cycle.export import export_cycle

    return export_cycle(optimize, scenario, out, options,
                        bench_session=bench_session, command_line=tuple(command_line))


def cycle_verify(store: str | Path = "bench_store", optimize: str | Path = "optimize_out",
                 out: str | Path = "verify_out", *, session: str | None = None,
                 command_line: Sequence[str] = ("drivebench.cycle_verify",)) -> Any:
    """Compare a cycle run in the store with the power model and the optimizer.

    Parameters
    ----------
    store : path
        The store holding the cycle-run session (:func:`ingest` of a ``kind =
        "cycle_run"`` session, docs/schemas.md §1).
    optimize : path
        The optimize folder its profile was exported from.
    out : path
        The output folder (docs/schemas.md §11).
    session : str, optional
        The session id; default the store's only cycle run.
    command_line : sequence of str
        Recorded in the provenance header.

    Returns
    -------
    cycle.verify_command.Verified
        ``.record`` (verify.json: means, bands, drift), ``.cycles`` (per cycle),
        ``.verdict`` (words).
    """
    from cycle.verify_command import verify_cycles

    return verify_cycles(store, optimize, out, session=session,
                         command_line=tuple(command_line))
