"""``bench fit`` as a library call: store -> power model, maps, selection, loss table, figures.

Writes the outputs of docs/schemas.md §4 into one directory, all of them or none
(:mod:`kernel.output_folder`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from bench.store.read import read_points, read_samples
from fitting import figures
from fitting.domain import BAND_FRAC, quadrant_envelopes
from fitting.efficiency import MaskingRules
from fitting.efficiency_map import efficiency_summary, gridded_map
from fitting.envelope_check import envelope_check
from fitting.extra_terms import extra_terms_check
from fitting.fit_folder import FIT_MARKERS, FitContents, write_fit_files
from fitting.points import QUADRANTS, OperatingPoints, load_points
from fitting.power_fit import (
    OUTLIER_ALPHA,
    FitResult,
    check_fit_input,
    fit_power_model,
    outlier_test,
    quadrant_weights,
)
from fitting.power_model import PowerModel
from fitting.rating import resolve_drive
from fitting.repeatability import loss_repeatability, repeatability, with_repeatability
from fitting.selection import (
    RULE,
    Candidate,
    SelectionResult,
    order_candidate,
    paper_candidate,
    paper_space_candidate,
    select_model,
)
from fitting.terms import MAX_ORDER, MIN_ORDER, full_polynomial
from fitting.thermal import fit_thermal
from kernel.errors import InputError
from kernel.files import check_output_dir, json_safe
from kernel.output_folder import check_replaceable, output_folder
from kernel.provenance import HEADER_KEY, Provenance

WEIGHTINGS = ("quadrant", "none")


@dataclass(frozen=True)
class FitOptions:
    """Options of one ``bench fit`` run.

    Parameters
    ----------
    order : int or None
        Total order 1..6 of the exported model; None selects it (``--order auto``).
    full_order2 : bool
        With ``order == 2``: the full 6-term polynomial instead of the paper's eq. 4.
    folds : int
        k of the k-fold cross-validation.
    weighting : str
        ``quadrant`` (each quadrant counts equally) or ``none`` (plain OLS).
    mask_mech_frac, mask_elec_frac, envelope_band_frac : float
        Masking settings (:class:`fitting.efficiency.MaskingRules`) [-].
    drive : dict
        Drive rating keys given on the command line (:data:`kernel.drive.DRIVE_KEYS`);
        the others come from the store
        manifest or the data (:func:`fitting.rating.resolve_drive`).
    command_line : tuple of str
        The command line, recorded in the provenance (:mod:`kernel.provenance`).
    """

    order: int | None = 2
    full_order2: bool = False
    folds: int = 5
    weighting: str = "quadrant"
    mask_mech_frac: float = 0.02
    mask_elec_frac: float = 0.02
    envelope_band_frac: float = BAND_FRAC
    drive: dict = field(default_factory=dict)
    command_line: tuple[str, ...] = ("bench", "fit")

    def __post_init__(self) -> None:
        if self.order is not None and not MIN_ORDER <= self.order <= MAX_ORDER:
            raise InputError(None, f"option --order: {self.order} is outside "
                             f"{MIN_ORDER}..{MAX_ORDER}", expected="an order 1..6 or 'auto'")
        if self.weighting not in WEIGHTINGS:
            raise InputError(None, f"option --weighting: {self.weighting!r}",
                             expected=" or ".join(WEIGHTINGS))
        if self.full_order2 and self.order != 2:
            raise InputError(None, "option --full applies to --order 2 only",
                             expected="--order 2 --full, or no --full")
        if self.folds < 2:
            raise InputError(None, f"option --folds: {self.folds}", expected="at least 2")

    def masking(self, nominal_power_w: float) -> MaskingRules:
        """The masking rules for a drive of this nominal power [W]."""
        try:
            return MaskingRules(nominal_power_w, mech_frac=self.mask_mech_frac,
                                elec_frac=self.mask_elec_frac,
                                envelope_band_frac=self.envelope_band_frac)
        except ValueError as exc:
            raise InputError(None, f"masking option: {exc}") from None

    def candidate(self) -> Candidate | None:
        """The requested candidate (None: chosen by the selection)."""
        if self.order is None:
            return None
        if self.order == 2 and not self.full_order2:
            return paper_candidate()
        return order_candidate(self.order)


@dataclass(frozen=True)
class FitPoints:
    """The store's points a fit runs on: the quadrants with enough of them.

    Parameters
    ----------
    points : OperatingPoints
        All points the store lists (their files and hashes).
    frame : pandas.DataFrame
        The points of the quadrants fitted.
    measured : list of str
        The quadrants fitted.
    dropped : dict
        quadrant -> point count of a quadrant with points but too few to fit.
    min_points : int
        Fewest points a quadrant needs (:func:`min_quadrant_points`).
    store : str
        The store, as given.
    """

    points: OperatingPoints
    frame: pd.DataFrame
    measured: list[str]
    dropped: dict[str, int]
    min_points: int
    store: str

    @property
    def source(self) -> Path:
        """The points' folder, named in errors."""
        return Path(self.store) / "points"

    def provenance(self, command_line: tuple[str, ...]) -> dict:
        """Where the model comes from: the points' files and hash, the store, the command."""
        return {"points_sha256": self.points.sha256, "points_files": self.points.files,
                "store": self.store, "command_line": list(command_line),
                "software": "drivebench fitting.pipeline"}

    def statement(self) -> dict:
        """Point counts per quadrant, the quadrants fitted and those dropped (statistics)."""
        return {"points_per_quadrant": self.points.counts(),
                "quadrants_measured": self.measured,
                "quadrants_dropped": {q: {"n_points": n, "min_points": self.min_points}
                                      for q, n in self.dropped.items()}}


def fit_points(store: str | Path, folds: int) -> FitPoints:
    """The store's points, the quadrants with fewer than :func:`min_quadrant_points` dropped.

    Raises
    ------
    InputError
        No quadrant has enough points.
    """
    points = load_points(store)
    counts = points.counts()
    need = min_quadrant_points(folds)
    measured = [q for q in QUADRANTS if counts[q] >= need]
    if not measured:
        raise InputError(Path(store) / "points", "no quadrant has enough points to fit and "
                         "cross-validate: " + ", ".join(f"{q} {counts[q]}" for q in QUADRANTS),
                         expected=f"at least {need} points in one quadrant ({folds} folds)")
    frame = points.frame[points.frame["quadrant"].isin(measured)].reset_index(drop=True)
    return FitPoints(points=points, frame=frame, measured=measured,
                     dropped={q: counts[q] for q in QUADRANTS if 0 < counts[q] < need},
                     min_points=need, store=str(store))


@dataclass(frozen=True, eq=False)
class ModelFit:
    """The exported fit and how it was chosen.

    Parameters
    ----------
    fit : FitResult
        The exported model's fit.
    selection : SelectionResult
        The model selection over all candidates.
    chosen : Candidate
        The exported candidate.
    requested : bool
        True when it was asked for (``--order``), not chosen by the selection.
    weights : numpy.ndarray
        The points' weights.
    extra_terms : dict
        The paper's extra-terms check (:func:`fitting.extra_terms.extra_terms_check`).
    """

    fit: FitResult
    selection: SelectionResult
    chosen: Candidate
    requested: bool
    weights: np.ndarray
    extra_terms: dict

    def statistics(self, weighting: str, frame: pd.DataFrame, points: dict,
                   outliers: dict) -> dict:
        """The ``statistics`` of the fit summary and the model file (before ``validity``)."""
        motor = frame["quadrant"].to_numpy() == "motor"
        return json_safe({**self.fit.summary(weighting, motor, points), "outliers": outliers,
                          "selection": self.selection.summary(self.chosen, self.requested)})

    def power_model(self, measured: list[str], envelopes: dict, **metadata) -> PowerModel:
        """The exported model: named for its candidate (and its one quadrant when only one
        was fitted), valid in the measured envelopes; ``metadata``: masking, statistics,
        provenance, drive."""
        only = "" if len(measured) == len(QUADRANTS) else f", {measured[0]} quadrant only"
        return self.fit.to_power_model(
            name=f"bench fit: {self.chosen.name} ({len(self.chosen.terms)} terms{only})",
            domain={q: env["polygon"] for q, env in envelopes.items()}, **metadata)

    def summary(self, model: PowerModel, statistics: dict, drive: dict, notes: list[str],
                efficiency: dict, header: dict) -> dict:
        """``fit_summary.json`` without its schema and its list of files (docs/schemas.md §4)."""
        return json_safe({
            "model": model.summary(), "statistics": statistics,
            "selection_table": self.selection.table.to_dict(orient="records"),
            "extra_terms_check": self.extra_terms, "drive": drive, "notes": notes,
            "efficiency": efficiency, HEADER_KEY: header})


def fit_model(frame: pd.DataFrame, drive, options: FitOptions, source: Path,
              progress: bool) -> ModelFit:
    """Fit the requested model (or the one the selection chooses), run the selection and
    the paper's extra-terms check."""
    nominal = drive.nominal_power_w
    speed = frame["speed_rpm"].to_numpy()
    torque = frame["torque_nm"].to_numpy()
    p_elec = frame["p_elec_w"].to_numpy()
    quadrant = frame["quadrant"].to_numpy()
    weights = (quadrant_weights(quadrant) if options.weighting == "quadrant"
               else np.ones(len(frame)))
    requested = options.candidate()
    fit = None
    if requested is not None:  # fit first: its errors (too few points, rank) are the clearest
        fit = fit_power_model(speed, torque, p_elec, requested.terms, weights=weights,
                              nominal_power_w=nominal, source=source)
    else:
        check_fit_input(full_polynomial(MIN_ORDER), len(frame), source)
    selection = select_model(speed, torque, p_elec, quadrant, weights, folds=options.folds,
                             nominal_power_w=nominal, source=source, progress=progress)
    chosen = requested or selection.chosen
    if fit is None:
        fit = fit_power_model(speed, torque, p_elec, chosen.terms, weights=weights,
                              nominal_power_w=nominal, source=source)
    rated_speed_rpm, rated_torque_nm = drive.box()
    try:
        extra = extra_terms_check(speed, torque, p_elec, weights,
                                  rated_speed_rpm=rated_speed_rpm,
                                  rated_torque_nm=rated_torque_nm,
                                  nominal_power_w=nominal, source=source)
    except InputError as exc:
        extra = {"space": paper_space_candidate().name, "skipped": exc.problem}
    return ModelFit(fit=fit, selection=selection, chosen=chosen,
                    requested=requested is not None, weights=weights, extra_terms=extra)


def _contents(model, emap: pd.DataFrame, masking: MaskingRules, fitted: ModelFit,
              options: FitOptions, points_sha256: str, summary: dict) -> FitContents:
    """The files of the fit folder: the model, its map, the selection table, the summary."""
    return FitContents(
        model=model, efficiency_map=emap,
        map_metadata={"masking": masking.to_dict(), "power_model_sha256": model.sha256,
                      "points_sha256": points_sha256},
        selection=fitted.selection.table,
        selection_metadata={"rule": RULE, "weighting": options.weighting,
                            "folds": options.folds, "reason": fitted.selection.reason},
        summary=summary)


def _figures(model, frame: pd.DataFrame, masking: MaskingRules, fitted: ModelFit,
             emap: pd.DataFrame) -> Callable[[Path], list[Path]]:
    """The fit's figures, drawn into the folder given."""
    def draw(fig_dir: Path) -> list[Path]:
        return (figures.efficiency_map_figure(emap, fig_dir, masking.to_dict(), model.domain)
                + figures.power_map_figure(model, frame, fig_dir)
                + figures.residuals_figure(frame, fitted.fit.residuals_w,
                                           model.nominal_power_w, fig_dir))
    return draw


def run_fit(store: str | Path, out: str | Path, options: FitOptions,
            progress: bool = True) -> dict:
    """Fit the store's operating points and write all outputs into ``out``.

    Parameters
    ----------
    store : str or Path
        Store directory written by ``bench ingest``.
    out : str or Path
        Output directory (created if missing).
    options : FitOptions
    progress : bool
        Show progress bars.

    Returns
    -------
    dict
        The content of ``fit_summary.json``.

    Raises
    ------
    InputError
        Missing or empty store, NaN values, too few points, a rank-deficient
        design, sessions that disagree on the drive rating.

    Notes
    -----
    A campaign that measured one quadrant only (motor or generator) is fitted on
    that quadrant; the model's validity domain then holds that quadrant alone,
    and the summary says so. A quadrant with fewer points than
    :func:`min_quadrant_points` (too few for the folds or the smallest model) is
    dropped and treated the same way, its point count stated.
    """
    check_output_dir(out)  # before the work, not after it
    check_replaceable(out, "fit", FIT_MARKERS)
    run = Provenance.start(options.command_line)
    pts = fit_points(store, options.folds)
    drive, drive_notes = resolve_drive(store, pts.frame, options.drive)
    masking = options.masking(drive.nominal_power_w)
    loss_repeat = loss_repeatability(pts.frame, masking)
    frame = with_repeatability(pts.frame, loss_repeat)  # each point's honest uncertainty
    fitted = fit_model(frame, drive, options, pts.source, progress)
    outliers = outlier_summary(frame, fitted.fit, fitted.weights, drive.nominal_power_w,
                               pts.source)
    statistics = fitted.statistics(options.weighting, frame, pts.statement(), outliers)
    envelopes = quadrant_envelopes(frame, masking.envelope_band_frac)
    statistics["validity"] = validity_statement(pts.points.counts(), envelopes, pts.min_points)
    checked = envelope_check(frame, drive)
    if checked is not None:
        statistics["envelope_check"] = checked
    provenance = pts.provenance(options.command_line)
    model = fitted.power_model(pts.measured, envelopes, masking=masking.to_dict(),
                               statistics=statistics, provenance=provenance,
                               drive=drive)
    thermal, thermal_note = fit_thermal(read_points(store),
                                        lambda sid: read_samples(store, sid))
    model = replace(model, thermal=thermal)
    repeats = repeatability(frame, masking)
    notes = ([thermal_note] + drive_notes + [v["note"] for v in statistics["validity"].values()
                            if not v["measured"]]
             + [d["note"] for d in (outliers, loss_repeat, repeats, checked or {})
                if d.get("note")])
    emap = gridded_map(frame, masking, model=model)
    efficiency = efficiency_summary(emap, frame, masking, loss_repeat, repeats, envelopes)
    summary = fitted.summary(model, statistics, drive.to_dict(), notes, efficiency,
                             {**run.header(), **provenance})
    contents = _contents(model, emap, masking, fitted, options, pts.points.sha256, summary)
    draw = _figures(model, frame, masking, fitted, emap)
    with output_folder(out, "fit", FIT_MARKERS, provenance=run) as stage:  # all or none
        return write_fit_files(stage, contents, draw)


def outlier_summary(frame, fit, weights: np.ndarray, nominal_power_w: float, source) -> dict:
    """Points with an extreme studentized residual (:func:`fitting.power_fit.outlier_test`)
    and the fit without them, side by side with the exported fit (which keeps them).

    Returns
    -------
    dict
        ``rule``, ``alpha``, ``critical_t``, ``n_flagged``, ``points`` (per flagged
        point: session, point id, speed, torque, p_elec, residual, studentized
        residual), and when any is flagged ``without`` (the refit's coefficients,
        residual statistics, ``max_abs_change_w`` of the model at the kept points and
        ``max_change_std_errors`` of the coefficients) and a one-line ``note``.
    """
    flagged, critical = outlier_test(fit)
    out = {"rule": "externally studentized residual beyond the Bonferroni critical value "
                   f"t(1 - alpha / (2 n), n - p - 1), alpha = {OUTLIER_ALPHA:g}; flagged points "
                   "are kept in the exported fit and shown here with the fit without them",
           "alpha": OUTLIER_ALPHA, "critical_t": critical, "n_flagged": int(flagged.sum()),
           "points": []}
    order = np.flatnonzero(flagged)[np.argsort(-np.abs(fit.studentized[flagged]))]
    for k in order:
        out["points"].append({
            "session_id": str(frame["session_id"].iloc[k]),
            "point_id": int(frame["point_id"].iloc[k]),
            "speed_rpm": float(frame["speed_rpm"].iloc[k]),
            "torque_nm": float(frame["torque_nm"].iloc[k]),
            "p_elec_w": float(frame["p_elec_w"].iloc[k]),
            "residual_w": float(fit.residuals_w[k]),
            "studentized": float(fit.studentized[k])})
    keep = ~flagged
    if not flagged.any():
        return out
    try:
        without = fit_power_model(frame["speed_rpm"].to_numpy()[keep],
                                  frame["torque_nm"].to_numpy()[keep],
                                  frame["p_elec_w"].to_numpy()[keep], fit.terms,
                                  weights=weights[keep], nominal_power_w=nominal_power_w,
                                  source=source)
    except InputError as exc:
        out["without"] = {"skipped": exc.problem}
        return out
    speed, torque = frame["speed_rpm"].to_numpy()[keep], frame["torque_nm"].to_numpy()[keep]
    change = np.abs(fit.to_power_model("with").p_elec_w(speed, torque)
                    - without.to_power_model("without").p_elec_w(speed, torque))
    shift = np.abs(without.coefficients_rpm - fit.coefficients_rpm) / fit.std_errors_rpm
    out["without"] = {"n_points": without.n_points, "coefficients": without.coefficient_table(),
                      "residuals": without.residual_stats(), "r2": without.r2,
                      "max_abs_change_w": float(change.max()),
                      "max_change_std_errors": float(np.max(shift))}
    out["note"] = _outlier_note(out, fit, without, float(change.max()), float(np.max(shift)))
    return out


def _outlier_note(out: dict, fit, without, max_change_w: float, max_shift: float) -> str:
    """One line on the flagged points, the worst of them and what the fit without them
    changes."""
    first, critical = out["points"][0], out["critical_t"]
    return (
        f"{out['n_flagged']} outlier point(s) with |studentized residual| > {critical:.3g} "
        f"(Bonferroni, alpha {OUTLIER_ALPHA:g}), the worst {first['session_id']} point "
        f"{first['point_id']} at {first['speed_rpm']:.4g} rpm, {first['torque_nm']:.4g} N m, "
        f"{first['p_elec_w']:.4g} W (residual {first['residual_w']:.4g} W, t = "
        f"{first['studentized']:.3g}); kept in the exported fit (residual RMS "
        f"{fit.residual_stats()['rmse_w']:.4g} W); without them RMS "
        f"{without.residual_stats()['rmse_w']:.4g} W, the model changes by at most "
        f"{max_change_w:.4g} W at the other points, the coefficients by at most "
        f"{max_shift:.3g} standard errors")


def min_quadrant_points(folds: int) -> int:
    """Fewest points a quadrant needs to be fitted: one per fold, and no fewer than
    the terms of the smallest candidate model; with fewer it counts as not measured."""
    return max(folds, len(full_polynomial(MIN_ORDER)))


def validity_statement(counts: dict[str, int], envelopes: dict[str, dict],
                       min_points: int = 1) -> dict:
    """Per quadrant: measured or not, points, and what the validity domain is.

    A quadrant with points but fewer than ``min_points`` was dropped from the fit
    and is reported as such (``dropped: true``).
    """
    out = {}
    for q in QUADRANTS:
        if 0 < counts[q] < min_points:
            out[q] = {"measured": False, "dropped": True, "n_points": counts[q],
                      "note": f"the {q} quadrant was dropped: {counts[q]} points, fewer than "
                              f"the {min_points} needed to fit and cross-validate it; the "
                              "model is fitted on the other quadrant only, is not valid "
                              f"in the {q} quadrant and the map does not show it"}
        elif q in envelopes:
            env = envelopes[q]
            out[q] = {"measured": True, "n_points": counts[q],
                      "domain": f"measured envelope ({len(env['polygon'])} vertices, speed "
                                f"bands of {env['band_width_rpm']:.4g} rpm)"}
        else:
            out[q] = {"measured": False, "n_points": counts[q],
                      "note": f"the {q} quadrant was not measured ({counts[q]} points): the "
                              "model is not valid there and the map does not show it"}
    return out
