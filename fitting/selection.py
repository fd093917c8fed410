"""Model selection over term lists: k-fold cross-validated RMSE and BIC.

Candidates: the paper's eq. (4), full polynomials of total order 1..6, and the
paper's check space (speed**0..6 x torque**0..4).

Quadrant weighting: every point of quadrant q weighs ``N / (2 n_q)``
(:func:`fitting.power_fit.quadrant_weights`), in the fits, in the held-out RMSE
and in the BIC, so each quadrant counts equally whatever its point density.
Folds are drawn per quadrant, so every fold holds both quadrants.

Choice rule (the "one-standard-error rule"): among the candidates whose
cross-validated RMSE is within one standard error (over the folds) of the
lowest, take the one with the fewest terms; break ties by BIC. This prefers
the simplest model the data cannot tell apart from the best one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from tqdm import tqdm

from fitting.power_fit import (
    MIN_POINTS,
    MIN_POINTS_PER_TERM,
    design_matrix,
    design_scales,
    fit_power_model,
)
from fitting.terms import (
    MAX_ORDER,
    MIN_ORDER,
    PAPER_TERMS,
    full_polynomial,
    paper_space,
)
from kernel.errors import InputError

RULE = (
    "one-standard-error rule: fewest terms among candidates whose k-fold CV RMSE "
    "(quadrant-weighted) is within one standard error of the lowest; ties broken by BIC"
)


@dataclass(frozen=True)
class Candidate:
    """A candidate term list.

    Parameters
    ----------
    name : str
        Label used in tables and outputs.
    terms : tuple of (int, int)
        Exponents (speed, torque).
    order : int
        Total order (highest i + j).
    """

    name: str
    terms: tuple[tuple[int, int], ...]
    order: int


def paper_candidate() -> Candidate:
    """The paper's eq. (4)."""
    return Candidate("paper eq. 4", PAPER_TERMS, 2)


def order_candidate(order: int) -> Candidate:
    """The full polynomial of total order ``order``."""
    return Candidate(f"order {order}", full_polynomial(order), order)


def paper_space_candidate() -> Candidate:
    """The paper's check space, speed up to ^6 and torque up to ^4."""
    terms = paper_space()
    return Candidate("paper space w^6 T^4", terms, max(i + j for i, j in terms))


def default_candidates() -> list[Candidate]:
    """Paper eq. 4, orders 1..6, and the paper's check space."""
    return (
        [paper_candidate()]
        + [order_candidate(n) for n in range(MIN_ORDER, MAX_ORDER + 1)]
        + [paper_space_candidate()]
    )


def stratified_folds(quadrant: np.ndarray, folds: int, seed: int = 0) -> np.ndarray:
    """Fold index (0..folds-1) per point, assigned round-robin within each quadrant
    after a seeded shuffle, so each fold holds a share of every quadrant."""
    quadrant = np.asarray(quadrant)
    rng = np.random.default_rng(seed)
    fold = np.empty(quadrant.size, dtype=int)
    for q in np.unique(quadrant):
        idx = np.flatnonzero(quadrant == q)
        rng.shuffle(idx)
        fold[idx] = np.arange(idx.size) % folds
    return fold


def _why_none_fitted(table: pd.DataFrame, n_points: int, folds: int) -> tuple[str, str]:
    """Problem and expectation of the error when every candidate was skipped."""
    n_train = n_points - -(-n_points // folds)  # the largest fold held out
    needed = min(max(MIN_POINTS, MIN_POINTS_PER_TERM * n) for n in table["n_terms"])
    if table["status"].str.startswith("skipped: too few points").all():
        total = -(-needed * folds // (folds - 1))
        return (f"no candidate model could be fitted: too few points for {folds}-fold "
                f"cross-validation: {n_points} points leave {n_train} to train on, the "
                f"smallest candidate needs {needed}",
                f"at least {total} points, or fewer folds (--folds)")
    reasons = "; ".join(dict.fromkeys(table["status"]))
    return (f"no candidate model could be fitted ({reasons})",
            "enough points spread over speed and torque")


def _weighted_rmse(r: np.ndarray, w: np.ndarray) -> float:
    return float(np.sqrt(np.sum(w * r**2) / np.sum(w)))


def cross_validate(candidate: Candidate, speed, torque, p, weights, fold) -> dict:
    """k-fold CV of one candidate (weighted least squares on the scaled design).

    Returns
    -------
    dict
        ``cv_rmse_w``: weighted RMSE over all held-out predictions [W];
        ``cv_rmse_se_w``: standard error of the per-fold RMSE [W];
        ``residuals``: held-out residual of every point [W].

    Raises
    ------
    numpy.linalg.LinAlgError
        If a training fold's design is rank deficient.
    """
    n_folds = int(fold.max()) + 1
    scales = design_scales(speed, torque)
    x = design_matrix(candidate.terms, speed, torque, scales)
    pred = np.empty_like(p)
    per_fold = []
    for k in range(n_folds):
        train, test = fold != k, fold == k
        sw = np.sqrt(weights[train])
        xw = x[train] * sw[:, None]
        beta, _, rank, _ = np.linalg.lstsq(xw, p[train] * sw, rcond=None)
        if rank < x.shape[1]:
            raise np.linalg.LinAlgError(f"rank-deficient design in fold {k}")
        pred[test] = x[test] @ beta
        per_fold.append(_weighted_rmse(p[test] - pred[test], weights[test]))
    per_fold = np.array(per_fold)
    return {
        "cv_rmse_w": _weighted_rmse(p - pred, weights),
        "cv_rmse_se_w": float(np.std(per_fold, ddof=1) / np.sqrt(n_folds)),
        "residuals": p - pred,
    }


@dataclass(frozen=True, eq=False)
class SelectionResult:
    """Candidate table, the chosen candidate and why.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per candidate (see :func:`select_model`).
    chosen : Candidate
    reason : str
    """

    table: pd.DataFrame
    chosen: Candidate
    reason: str

    def summary(self, exported: Candidate, requested: bool) -> dict:
        """The fit summary's ``selection`` statement: the choice, the rule, why, and what
        was exported (``requested``: the exported model was asked for with ``--order``)."""
        return {"chosen_by_selection": self.chosen.name, "rule": RULE,
                "reason": self.reason, "exported": exported.name,
                "exported_because": "requested with --order" if requested
                else "chosen by the selection"}


@dataclass(frozen=True, eq=False)
class _Points:
    """The points a selection compares the candidates on, and their folds."""

    speed: np.ndarray
    torque: np.ndarray
    p: np.ndarray
    quadrant: np.ndarray
    weights: np.ndarray
    fold: np.ndarray
    folds: int


def _candidate_row(cand: Candidate, pts: _Points, nominal_power_w: float, source) -> dict:
    """One row of the selection table: the candidate's CV and fit statistics, or why it
    was skipped."""
    row = {"candidate": cand.name, "order": cand.order, "n_terms": len(cand.terms)}
    n_train_min = int(np.min([np.sum(pts.fold != k) for k in range(pts.folds)]))
    needed = max(MIN_POINTS, MIN_POINTS_PER_TERM * len(cand.terms))
    if n_train_min < needed:
        return row | {"status": f"skipped: too few points ({n_train_min} < {needed})"}
    try:
        cv = cross_validate(cand, pts.speed, pts.torque, pts.p, pts.weights, pts.fold)
        fit = fit_power_model(pts.speed, pts.torque, pts.p, cand.terms, weights=pts.weights,
                              nominal_power_w=nominal_power_w, source=source)
    except (np.linalg.LinAlgError, InputError) as exc:
        return row | {"status": f"skipped: {exc}"}
    r, quadrant = cv["residuals"], pts.quadrant
    return row | {
        "status": "ok",
        "cv_rmse_w": cv["cv_rmse_w"],
        "cv_rmse_se_w": cv["cv_rmse_se_w"],
        "cv_rmse_pct_nominal": 100.0 * cv["cv_rmse_w"] / nominal_power_w,
        "cv_rmse_motor_w": float(np.sqrt(np.mean(r[quadrant == "motor"] ** 2)))
        if np.any(quadrant == "motor") else np.nan,
        "cv_rmse_generator_w": float(np.sqrt(np.mean(r[quadrant == "generator"] ** 2)))
        if np.any(quadrant == "generator") else np.nan,
        "bic": fit.bic,
        "fit_rmse_w": float(np.sqrt(np.mean(fit.residuals_w**2))),
        "r2": fit.r2,
        "condition_number": fit.condition_number,
    }


def _choose(table: pd.DataFrame, candidates: list[Candidate], n_points: int, folds: int,
            source) -> SelectionResult:
    """Apply the one-standard-error rule to the selection table (module docstring)."""
    for col in ("cv_rmse_w", "cv_rmse_se_w", "bic"):
        if col not in table:
            table[col] = np.nan
    ok = table["status"] == "ok"
    if not ok.any():
        problem, expected = _why_none_fitted(table, n_points, folds)
        raise InputError(source, problem, expected=expected)
    table["delta_bic"] = table["bic"] - table.loc[ok, "bic"].min()
    best = table.loc[ok, "cv_rmse_w"].idxmin()
    limit = table.at[best, "cv_rmse_w"] + table.at[best, "cv_rmse_se_w"]
    eligible = table[ok & (table["cv_rmse_w"] <= limit)]
    pick = eligible.sort_values(["n_terms", "bic"]).index[0]
    table["chosen"] = table.index == pick
    chosen = {c.name: c for c in candidates}[table.at[pick, "candidate"]]
    bic_best = table.loc[table.loc[ok, "bic"].idxmin(), "candidate"]
    reason = (
        f"{chosen.name} ({len(chosen.terms)} terms): CV RMSE "
        f"{table.at[pick, 'cv_rmse_w']:.1f} W is within one standard error of the lowest "
        f"({table.at[best, 'candidate']}: {table.at[best, 'cv_rmse_w']:.1f} W "
        f"+ {table.at[best, 'cv_rmse_se_w']:.1f} W) and has the fewest terms of the "
        f"{len(eligible)} candidate(s) within that band; "
        + ("BIC agrees (lowest BIC)." if bic_best == chosen.name
           else f"lowest BIC: {bic_best} (delta BIC of the choice "
                f"{table.at[pick, 'delta_bic']:.1f}).")
    )
    return SelectionResult(table=table, chosen=chosen, reason=reason)


def select_model(
    speed_rpm,
    torque_nm,
    p_elec_w,
    quadrant,
    weights,
    *,
    folds: int = 5,
    candidates: list[Candidate] | None = None,
    nominal_power_w: float,
    seed: int = 0,
    source=None,
    progress: bool = False,
) -> SelectionResult:
    """Compare candidates by k-fold CV RMSE and BIC and choose one (see module docstring).

    Parameters
    ----------
    speed_rpm, torque_nm, p_elec_w : numpy.ndarray
        Operating points [rpm], [N m], [W].
    quadrant : numpy.ndarray of str
        ``motor``/``generator`` per point (folds are stratified on it).
    weights : numpy.ndarray
        Point weights (mean 1), e.g. :func:`fitting.power_fit.quadrant_weights`.
    folds : int
        Number of folds (>= 2).
    candidates : list of Candidate, optional
        Defaults to :func:`default_candidates`.
    nominal_power_w : float
        For the relative columns [W].
    seed : int
        Seed of the fold assignment.
    source : str or Path, optional
        Named in errors.
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    SelectionResult
        ``table`` columns: ``candidate, order, n_terms, status, cv_rmse_w,
        cv_rmse_se_w, cv_rmse_pct_nominal, cv_rmse_motor_w, cv_rmse_generator_w,
        bic, delta_bic, fit_rmse_w, r2, chosen``.
    """
    speed = np.asarray(speed_rpm, dtype=float)
    torque = np.asarray(torque_nm, dtype=float)
    p = np.asarray(p_elec_w, dtype=float)
    quadrant = np.asarray(quadrant)
    weights = np.asarray(weights, dtype=float)
    if folds < 2:
        raise InputError(source, f"{folds} folds", expected="at least 2 folds")
    smallest = min(np.unique(quadrant, return_counts=True)[1])
    if smallest < folds:
        raise InputError(source, f"a quadrant has {smallest} points, fewer than {folds} folds",
                         expected="at least one point per fold in each quadrant")
    pts = _Points(speed=speed, torque=torque, p=p, quadrant=quadrant, weights=weights,
                  fold=stratified_folds(quadrant, folds, seed), folds=folds)
    candidates = candidates or default_candidates()
    rows = [_candidate_row(cand, pts, nominal_power_w, source)
            for cand in tqdm(candidates, desc="model selection", disable=not progress,
                             leave=False)]
    return _choose(pd.DataFrame(rows), candidates, pts.speed.size, folds, source)
