"""``bench fit`` as a library call: store -> power model, maps, selection, loss table, figures.

Writes the outputs of docs/schemas.md §4 into one directory, all of them or none
(:mod:`kernel.output_folder`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fitting import figures
from fitting.domain import BAND_FRAC, quadrant_envelopes
from fitting.efficiency import (
    MaskingRules,
    band_shares,
    gridded_map,
    loss_repeatability,
    peak_points,
    points_against_map,
    repeatability,
    with_repeatability,
)
from fitting.loss_table import write_loss_table
from fitting.model_file import save_power_model
from fitting.points import QUADRANTS, load_points
from fitting.power_fit import (
    OUTLIER_ALPHA,
    check_fit_input,
    fit_power_model,
    outlier_test,
    quadrant_weights,
)
from fitting.rating import resolve_drive
from fitting.selection import (
    RULE,
    Candidate,
    extra_terms_check,
    order_candidate,
    paper_candidate,
    paper_space_candidate,
    select_model,
)
from fitting.terms import MAX_ORDER, MIN_ORDER, full_polynomial
from kernel.errors import InputError
from kernel.files import check_output_dir, json_safe, write_json, write_parquet
from kernel.output_folder import check_replaceable, output_folder
from kernel.provenance import HEADER_KEY, Provenance

WEIGHTINGS = ("quadrant", "none")
#: files by which a fit output folder written before run ids is known
FIT_MARKERS = ("fit_summary.json", "power_model.json")


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
        Drive rating keys given on the command line (``nominal_power_w``,
        ``max_speed_rpm``, ``max_torque_nm``); the others come from the store
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
    prov = Provenance.start(options.command_line)
    points = load_points(store)
    source = Path(store) / "points"
    counts = points.counts()
    need = min_quadrant_points(options.folds)
    measured = [q for q in QUADRANTS if counts[q] >= need]
    dropped = {q: counts[q] for q in QUADRANTS if 0 < counts[q] < need}
    if not measured:
        raise InputError(source, "no quadrant has enough points to fit and cross-validate: "
                         + ", ".join(f"{q} {counts[q]}" for q in QUADRANTS),
                         expected=f"at least {need} points in one quadrant "
                                  f"({options.folds} folds)")
    frame = points.frame[points.frame["quadrant"].isin(measured)].reset_index(drop=True)
    drive, drive_notes = resolve_drive(store, frame, options.drive)
    masking = options.masking(drive.nominal_power_w)
    loss_repeat = loss_repeatability(frame, masking)
    frame = with_repeatability(frame, loss_repeat)  # each point's honest uncertainty
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
                             nominal_power_w=nominal, source=source,
                             progress=progress)
    chosen = requested or selection.chosen
    if fit is None:
        fit = fit_power_model(speed, torque, p_elec, chosen.terms, weights=weights,
                              nominal_power_w=nominal, source=source)
    try:
        extra = extra_terms_check(speed, torque, p_elec, weights,
                                  rated_speed_rpm=drive.max_speed_rpm,
                                  rated_torque_nm=drive.max_torque_nm,
                                  nominal_power_w=nominal, source=source)
    except InputError as exc:
        extra = {"space": paper_space_candidate().name, "skipped": exc.problem}

    outliers = outlier_summary(frame, fit, weights, nominal, source)
    repeats = repeatability(frame, masking)
    motor = quadrant == "motor"
    statistics = {
        "method": "weighted least squares (statsmodels WLS)" if options.weighting == "quadrant"
        else "ordinary least squares (statsmodels OLS)",
        "weighting": options.weighting,
        "n_points": fit.n_points,
        "points_per_quadrant": counts,
        "quadrants_measured": measured,
        "quadrants_dropped": {q: {"n_points": n, "min_points": need} for q, n in
                              dropped.items()},
        "r2": fit.r2,
        "r2_weighted": fit.r2_weighted,
        "bic": fit.bic,
        "condition_number_scaled_design": fit.condition_number,
        "residuals": {"all": fit.residual_stats(), "motor": fit.residual_stats(motor),
                      "generator": fit.residual_stats(~motor)},
        "normality": fit.normality(),
        "coefficients": fit.coefficient_table(),
        "outliers": outliers,
        "selection": {"chosen_by_selection": selection.chosen.name, "rule": RULE,
                      "reason": selection.reason, "exported": chosen.name,
                      "exported_because": "chosen by the selection" if requested is None
                      else "requested with --order"},
    }
    statistics = json_safe(statistics)
    provenance = {
        "points_sha256": points.sha256,
        "points_files": points.files,
        "store": str(store),
        "command_line": list(options.command_line),
        "software": "drivebench fitting.pipeline",
    }
    envelopes = quadrant_envelopes(frame, masking.envelope_band_frac)
    statistics["validity"] = validity_statement(counts, envelopes, need)
    only = "" if len(measured) == len(QUADRANTS) else f", {measured[0]} quadrant only"
    model = fit.to_power_model(
        name=f"bench fit: {chosen.name} ({len(chosen.terms)} terms{only})",
        domain={q: env["polygon"] for q, env in envelopes.items()},
        masking=masking.to_dict(),
        statistics=statistics,
        provenance=provenance,
        drive=drive.to_dict(),
    )

    with output_folder(out, "fit", FIT_MARKERS, provenance=prov) as stage:  # all or none
        (stage / "figures").mkdir()
        written = [save_power_model(model, stage / "power_model.json")]

        emap = gridded_map(frame, masking, model=model)
        shares = band_shares(emap)
        peaks = peak_points(emap, frame, masking)
        meta = {"masking": masking.to_dict(), "power_model_sha256": model.sha256,
                "points_sha256": points.sha256}
        written.append(write_parquet(stage / "efficiency_map.parquet", emap, metadata=meta))
        table = selection.table.copy()
        written.append(write_parquet(stage / "selection.parquet", table, metadata={
            "rule": RULE, "weighting": options.weighting, "folds": options.folds,
            "reason": selection.reason}))
        written.append(write_loss_table(model, stage / "loss_table.csv"))
        fig_dir = stage / "figures"
        written += figures.efficiency_map_figure(emap, fig_dir, masking.to_dict(), model.domain)
        written += figures.power_map_figure(model, frame, fig_dir)
        written += figures.residuals_figure(frame, fit.residuals_w, nominal, fig_dir)

        summary = {
            "schema": "drivebench.fit_summary",
            "schema_version": 1,
            "model": {"name": model.name, "sha256": model.sha256, "terms": [list(t) for t in
                      model.terms], "coefficients_rpm": list(model.coefficients_rpm),
                      "coefficients_si": list(model.coefficients_si)},
            "statistics": statistics,
            "selection_table": _records(table),
            "extra_terms_check": extra,
            "drive": drive.to_dict(),
            "notes": drive_notes + [v["note"] for v in statistics["validity"].values()
                                    if not v["measured"]]
            + [d["note"] for d in (outliers, loss_repeat, repeats) if d.get("note")],
            "efficiency": {"masking": masking.to_dict(), "band_shares": _records(shares),
                           "peak": peaks,
                           "points_against_map": points_against_map(
                               frame, masking, emap, emap.attrs["ceilings"]),
                           "loss_repeatability": loss_repeat,
                           "repeatability": repeats,
                           "envelope": {q: {"band_width_rpm": env["band_width_rpm"],
                                            "n_points": env["n_points"],
                                            "n_vertices": len(env["polygon"])}
                                        for q, env in envelopes.items()}},
            HEADER_KEY: {**prov.header(), **provenance},
            "outputs": sorted(str(p.relative_to(stage)) for p in written) + ["fit_summary.json"],
        }
        summary = json_safe(summary)
        write_json(stage / "fit_summary.json", summary)
    return summary


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
    first = out["points"][0]
    out["note"] = (
        f"{out['n_flagged']} outlier point(s) with |studentized residual| > {critical:.3g} "
        f"(Bonferroni, alpha {OUTLIER_ALPHA:g}), the worst {first['session_id']} point "
        f"{first['point_id']} at {first['speed_rpm']:.4g} rpm, {first['torque_nm']:.4g} N m, "
        f"{first['p_elec_w']:.4g} W (residual {first['residual_w']:.4g} W, t = "
        f"{first['studentized']:.3g}); kept in the exported fit (residual RMS "
        f"{fit.residual_stats()['rmse_w']:.4g} W); without them RMS "
        f"{without.residual_stats()['rmse_w']:.4g} W, the model changes by at most "
        f"{change.max():.4g} W at the other points, the coefficients by at most "
        f"{np.max(shift):.3g} standard errors")
    return out


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


def _records(frame) -> list[dict]:
    """Rows as JSON-safe dicts."""
    return json_safe(frame.to_dict(orient="records"))
