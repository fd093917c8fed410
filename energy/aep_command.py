"""The whole ``bench aep`` command as a library call: :func:`run_aep`.

Read the sweep (:func:`energy.curve.read_optimize_run`), optionally solve added wind
speeds where each kind's curve bends for the site (:mod:`energy.refine`), assess the
annual energy (:func:`energy.assess.assess`) and write the files
(:func:`energy.outputs.write_outputs`). ``bench aep`` and :func:`drivebench.api.aep`
both call it with the same option objects.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from energy.assess import SiteUncertainty, assess, model_for_run
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
from kernel.errors import InputError
from kernel.output_folder import check_replaceable
from kernel.provenance import Provenance
from optimize.door import CALL_WALL_LIMIT_S, LOCAL_POOL, Execution, check_call_time_limit


@dataclass(frozen=True)
class SiteSpec:
    """The site of an assessment.

    Attributes
    ----------
    distribution : energy.site.Weibull or energy.site.Histogram
        Wind-speed distribution at the sweep's reference height.
    note : str or None
        How the site was given, for the outputs (None: its description and height).
    uncertainty : SiteUncertainty or None
        One-sigma errors of a Weibull site's parameters.
    shear : energy.site.Shear or None
        The wind profile (None: the sweep's system's ``[wind]``).
    """

    distribution: Any
    note: str | None = None
    uncertainty: SiteUncertainty | None = None
    shear: Shear | None = None


@dataclass(frozen=True)
class RefineOptions:
    """``bench aep --refine``: added wind speeds where each kind's curve bends.

    Attributes
    ----------
    tol : float
        Stop when every interval's estimated error is below this share of the AEP.
    max_points : int
        Largest grid per kind, failed solves included.
    call_time_limit_s : float
        The longest one solver call may run [s] (``--call-time-limit``; it replaces the
        sweep's, :attr:`optimize.problem.options.SolverOptions.call_time_limit_s`).

    Raises
    ------
    InputError
        ``tol`` not in (0, 1), ``max_points`` < 2 or ``call_time_limit_s`` not positive.
    """

    tol: float = DEFAULT_TOL
    max_points: int = 25
    call_time_limit_s: float = CALL_WALL_LIMIT_S

    def __post_init__(self) -> None:
        check_call_time_limit(self.call_time_limit_s)
        if not (math.isfinite(self.tol) and 0 < self.tol < 1):
            raise InputError(None, f"--refine-tol {self.tol}", expected="a share in (0, 1)")
        if self.max_points < 2:
            raise InputError(None, f"--refine-max-points {self.max_points}",
                             expected="--refine-max-points >= 2")


@dataclass(frozen=True)
class AepRun:
    """What :func:`run_aep` produced (the files are already written).

    Attributes
    ----------
    assessment : energy.assess.Assessment
        AEP, capacity factor, bands and losses per scenario kind.
    refined : energy.refine.RefinedRun or None
        The refined curves and their solves, else None.
    refine_document : dict or None
        The ``refine`` object of ``aep.json``.
    site_note : str
        The site as the outputs state it.
    files : dict
        Name -> written path.
    """

    assessment: Any
    refined: Any
    refine_document: dict | None
    site_note: str
    files: dict


def run_aep(sweep_folder: str | Path, site: SiteSpec, *, out: str | Path = "aep_out",
            drive_model: str | Path | None = None, nominal_power_w: float | None = None,
            refine: RefineOptions | None = None, execution: Execution = LOCAL_POOL,
            command_line: Sequence[str] = ("drivebench.aep",)) -> AepRun:
    """Annual energy of a sweep's power curves at a site, and ``bench aep``'s files.

    Parameters
    ----------
    sweep_folder : path
        A ``bench optimize`` output folder.
    site : SiteSpec
        The site (distribution, note, uncertainty, wind profile).
    out : path
        Output folder (``aep.json``, ``power_curves.csv``, awesIO files; docs/schemas.md §7).
    drive_model : path, optional
        The power model file (default the one the sweep's manifest names).
    nominal_power_w : float, optional
        Overrides the model's nominal power for the capacity factor [W].
    refine : RefineOptions, optional
        Solve added wind speeds through the solve service (``execution`` runs them).
    command_line : sequence of str
        Recorded in the provenance header.
    """
    run_record = Provenance.start(command_line)
    folder = Path(sweep_folder)
    out = check_replaceable(out, "aep", AEP_MARKERS, keep=AEP_KEEP)  # before the work
    run = read_optimize_run(folder)
    shear = site.shear
    if shear is None:
        system = system_from_manifest(run.manifest, folder / "manifest.json")
        shear = Shear() if system is None else Shear.from_system(system.wind)
    note = site.note or f"{site.distribution.describe()} at {shear.reference_height_m:g} m"
    refined = doc = None
    if refine is not None:
        refined = _refined(run, drive_model, site.distribution, refine, execution, out)
        doc = refine_document(refined, site.distribution, refine.tol)
    assessment = assess(refined.run if refined else run, site.distribution, note,
                        drive_model=drive_model, nominal_power_w=nominal_power_w,
                        site_uncertainty=site.uncertainty,
                        gradients=refined.gradients if refined else None)
    if refined is not None:
        assessment = dataclasses.replace(assessment,
                                         notes=assessment.notes + refine_notes(doc))
    files = write_outputs(assessment, refined.run if refined else run, out, run_record,
                          shear, refine=doc)
    return AepRun(assessment, refined, doc, note, files)


def _refined(run: Any, drive_model: str | Path | None, distribution: Any,
             refine: RefineOptions, execution: Execution, out: Path) -> Any:
    """The sweep's curves refined for the site (:func:`energy.refine.refine_run`)."""
    if execution.workers < 1:
        raise InputError(None, f"--workers {execution.workers}", expected="--workers >= 1")
    path, model_json = model_for_run(run, drive_model)
    if model_json is None:
        raise InputError(path, "power model file not found (--refine solves with it)",
                         expected="the sweep's power model, or --drive-model FILE")
    return refine_run(run, power_model_from_dict(model_json, path), distribution,
                      out / "solves", tol=refine.tol, max_points=refine.max_points,
                      call_time_limit_s=refine.call_time_limit_s,
                      workers=execution.workers, scheduler=execution.scheduler,
                      show_progress=execution.progress)
