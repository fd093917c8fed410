"""The whole ``bench size`` command as a library call: :func:`run_size`.

Make the candidate drives (:func:`energy.candidates.build_candidates`), size them at the
site, adding a scale beyond the edge while the best is the largest or smallest
(:func:`energy.sizing.size_extending`), and write the files
(:func:`energy.sizing_files.write_sizing`). ``bench size`` and :func:`drivebench.api.size`
both call it with the same option objects.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from energy.candidates import build_candidates
from energy.decision import covering_sizing_grid, decision, grid_coverage, grid_spec
from energy.sizing import (
    candidate_row,
    idle_lines,
    limits_text,
    run_sizing,
    size_extending,
    starts_note,
)
from energy.sizing_files import SIZE_KEEP, SIZE_MARKERS, edge_note, write_sizing
from kernel.drive import Drive
from kernel.errors import InputError
from kernel.output_folder import check_replaceable
from kernel.provenance import Provenance
from optimize.door import (
    DEFAULT_SOLVER,
    LOCAL_POOL,
    Execution,
    SolverChoice,
    check_call_time_limit,
)


@dataclass(frozen=True)
class SizingGrid:
    """The candidates and wind speeds of a sizing.

    Attributes
    ----------
    scales : tuple of float
        Torque-rating scales of the reference drive (docs/schemas.md §8: the law).
    models : tuple of Path
        Further candidates: power-model files with their own ``drive`` rating.
    wind_speeds_m_s : tuple of float or None
        Wind speeds [m/s] solved per candidate (at least two); None: the grid that covers
        the site (:func:`energy.decision.covering_sizing_grid`).
    tolerance : float
        The chosen drive is the smallest within this share of the best AEP.
    extend : int
        While the best drive is the largest or smallest scale, add one beyond it and size
        again, up to this many times.
    adaptive : bool
        Refine each candidate's grid where its curve bends for the site.

    Raises
    ------
    InputError
        Fewer than two wind speeds, a tolerance outside [0, 1), ``extend`` < 0, a scale
        that is not a distinct number > 0.
    """

    scales: tuple[float, ...] = (0.5, 1.0, 2.0)
    models: tuple[Path, ...] = ()
    wind_speeds_m_s: tuple[float, ...] | None = None
    tolerance: float = 0.02
    extend: int = 1
    adaptive: bool = False

    def __post_init__(self) -> None:
        for name in ("scales", "wind_speeds_m_s"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
        object.__setattr__(self, "models", tuple(Path(m) for m in self.models))
        if self.wind_speeds_m_s is not None and len(self.wind_speeds_m_s) < 2:
            spec = ",".join(f"{w:g}" for w in self.wind_speeds_m_s)
            raise InputError(None, f"--wind-grid {spec}: "
                             "one wind speed gives no AEP curve to integrate",
                             expected="at least two wind speeds")
        if not 0 <= self.tolerance < 1:
            raise InputError(None, f"--tolerance {self.tolerance}", expected="a share in [0, 1)")
        if self.extend < 0:
            raise InputError(None, f"--extend {self.extend}", expected="an integer >= 0")
        s = self.scales
        if not s or any(not (math.isfinite(v) and v > 0) for v in s) or len(set(s)) != len(s):
            raise InputError(None, f"--scales {','.join(f'{v:g}' for v in s)}",
                             expected="distinct scales > 0")


#: Overrides of the reference drive's rating: a :class:`kernel.drive.Drive` that states
#: only the keys it overrides, of :data:`energy.candidates.OVERRIDE_KEYS` (None: the
#: system's ``[drive]``, the limits ``bench optimize`` flies).
RatingOverrides = Drive

#: the defaults as objects, for signatures (frozen, so shared safely)
DEFAULT_SIZING = SizingGrid()
SYSTEM_RATING = Drive()


@dataclass(frozen=True)
class SizeRun:
    """What :func:`run_size` produced (the files are already written).

    Attributes
    ----------
    sizing : energy.sizing.SizingResult
        The candidate table, every solve record, the best and the chosen candidate.
    drive : kernel.drive.Drive
        The reference drive (rating, envelope and losses) the candidates are scaled from.
    notes : tuple of str
        What was assumed (a rating the system file does not state, the grid's hours).
    files : dict
        Name -> written path (empty when the earlier output was kept).
    kept : str or None
        Why the earlier output in the folder was kept and nothing written
        (:func:`earlier_is_better`); None when this run's files were written.
    decision : dict
        Whether the choice holds for the site (:func:`energy.decision.decision`).
    wind_speeds_m_s : tuple of float
        The sizing grid solved.
    """

    sizing: Any
    drive: Any
    notes: tuple[str, ...]
    files: dict
    kept: str | None = None
    decision: dict = field(default_factory=dict)
    wind_speeds_m_s: tuple[float, ...] = ()


def earlier_is_better(out: Path, sizing: Any) -> str | None:
    """Why the sizing already in ``out`` must not be replaced by ``sizing``: this run lost
    an AEP the earlier one has by solves that crashed (not stored; a re-run tries them
    again), not by the solver's verdict. None when this run's output may replace it."""
    from energy.sizing_files import read_sizing
    from optimize.door import transient

    crashed = [r for r in sizing.records if transient(r)]
    if not crashed or not (Path(out) / "sizing.json").is_file():
        return None
    try:
        earlier = read_sizing(Path(out))
    except (InputError, OSError):
        return None  # no readable earlier sizing: nothing better to keep
    had = {c.get("candidate") for c in earlier.get("candidates", [])
           if isinstance(c, dict) and c.get("aep_elec_mwh") is not None}
    now = set(sizing.table.dropna(subset=["aep_elec_mwh"])["candidate"])
    lost = sorted(had - now, key=str)
    if not lost:
        return None
    first = crashed[0]
    return (f"the sizing already in {out} is kept (nothing written): it has an AEP for "
            f"{', '.join(map(str, lost))}, this run has none because {len(crashed)} solve"
            f"{'s' * (len(crashed) > 1)} crashed (first {first.get('candidate', '')} "
            f"{first['wind_speed_m_s']:g} m/s: {first['status']}); a re-run solves them again")


def _checked_candidates(drive: Any, grid: SizingGrid, rating: Drive,
                        solver: SolverChoice, system: Any
                        ) -> Callable[[tuple[float, ...]], tuple[list, list[str]]]:
    """``candidates(scales)``: the candidates of ``scales`` and the models, and what was
    said of them, each checked once as bench optimize checks the system's drive before
    its first solve (InputError: refused)."""
    checked: set[str] = set()

    def candidates(scales: tuple[float, ...]) -> tuple[list, list[str]]:
        made, said = build_candidates(drive, scales, grid.models, rating)
        for c in made:
            if c.name not in checked:
                c.check(system)
                checked.add(c.name)
        return made, said

    return candidates


def _sizing_speeds(grid: SizingGrid, site: Any) -> tuple[tuple[float, ...], list[str]]:
    """The sizing's wind speeds [m/s]: the grid's, else one that covers the site (said)."""
    if grid.wind_speeds_m_s is not None:
        return grid.wind_speeds_m_s, []
    speeds = covering_sizing_grid(site)
    return speeds, [f"sizing grid {grid_spec(speeds)} m/s: it covers the site (no "
                    "--wind-grid given)"]


def run_size(site: Any, drive_model: Any = None, *, system: Any = None,
             fit_default: str | Path | None = None, grid: SizingGrid = DEFAULT_SIZING,
             rating: Drive = SYSTEM_RATING, solver: SolverChoice = DEFAULT_SOLVER,
             execution: Execution = LOCAL_POOL, out: str | Path = "size_out",
             site_note: str | None = None, command_line: Sequence[str] = ("drivebench.size",),
             before_solving: Callable[[Any, int, tuple], None] | None = None) -> SizeRun:
    """Size the drive: electrical AEP at ``site`` of the system's drive scaled in torque.

    Parameters
    ----------
    site : energy.site.Weibull or energy.site.Histogram
        Wind-speed distribution at the reference height.
    drive_model : PowerModel or path, optional
        The reference drive's losses; default the system file's, else ``fit_default``
        when it exists, else the paper's model
        (:func:`optimize.system.drive_in_force.drive_in_force`).
    system : System or path, optional
        The system file (its ``[drive]`` is the reference rating); default the shipped one.
    fit_default : path, optional
        ``bench fit``'s model, used when the system file names no losses.
    grid, rating : SizingGrid, kernel.drive.Drive
        The candidates, wind speeds and choice rule; the reference rating's overrides.
    solver, execution : SolverChoice, Execution
        The collocation grid of each solve (``n_intervals``, ``degree``) and the longest
        one solver call may run (``call_time_limit_s``); where they run.
    out : path
        Output folder (``sizing.json``, ``sizing.csv``, the resumable ``solves/``).
    site_note : str, optional
        How the site was given (default its description).
    command_line : sequence of str
        Recorded in the provenance header.
    before_solving : callable, optional
        ``before_solving(setup, n_candidates, wind_speeds_m_s)`` (``setup``: the system,
        the reference drive and how it was resolved, :class:`optimize.resolve.Setup`),
        called once the candidates and the wind grid are made.
    """
    from optimize.door import rejected_lines, resolve

    run_record = Provenance.start(command_line)
    check_call_time_limit(solver.call_time_limit_s)
    check_replaceable(out, "size", SIZE_MARKERS, keep=SIZE_KEEP)  # before the work
    setup = resolve(system, drive_model, fit_default=fit_default)
    system, drive = setup.system, setup.drive

    candidates = _checked_candidates(drive, grid, rating, solver, system)
    first, notes = candidates(grid.scales)
    notes = [setup.thermal_line(),
             *(f"{c.name} flies {limits_text(candidate_row(c))}" for c in first
               if c.scale == 1.0), *notes]
    wind_speeds_m_s, grid_note = _sizing_speeds(grid, site)
    notes += grid_note
    if before_solving is not None:
        before_solving(setup, len(first), wind_speeds_m_s)
    refused: list[str] = []
    result, edge, added = size_extending(
        lambda scales: candidates(scales)[0], grid.scales, grid.extend,
        lambda cands: run_sizing(cands, wind_speeds_m_s, site, Path(out), solver.n_intervals,
                                 solver.degree, call_time_limit_s=solver.call_time_limit_s,
                                 workers=execution.workers,
                                 scheduler=execution.scheduler,
                                 show_progress=execution.progress, tolerance=grid.tolerance,
                                 adaptive=grid.adaptive, system=system), refused)
    edge_doc = {"best_at": edge, "added_scales": added,
                "note": edge_note(edge, result.best, added)}
    coverage = grid_coverage(site, wind_speeds_m_s, result.records)
    choice = decision(result.table, result.records, site, coverage, grid.tolerance)
    notes = [*notes, *rejected_lines(result.records),
             *idle_lines(result.table, result.records), coverage["note"],
             starts_note(result.records, result.reference),
             *([edge_doc["note"]] if edge_doc["note"] else []), *refused]
    kept = earlier_is_better(Path(out), result)
    if kept is not None:
        return SizeRun(result, drive, (*notes, kept), {}, kept, choice, wind_speeds_m_s)
    files = write_sizing(Path(out), result, site=site, site_note=site_note or site.describe(),
                         drive=drive, resolution=setup.resolution, system=system,
                         wind_speeds_m_s=wind_speeds_m_s,
                         adaptive=grid.adaptive, tolerance=grid.tolerance, notes=notes,
                         provenance=run_record, edge=edge_doc, coverage=coverage,
                         decision=choice)
    return SizeRun(result, drive, tuple(notes), files, None, choice, wind_speeds_m_s)
