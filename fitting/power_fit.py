"""Least-squares fit of the polynomial power model (paper eq. 4 and generalisations).

The design is built in scaled variables (speed / speed scale, torque / torque
scale, both of order one) so that high-order term lists stay well conditioned;
coefficients, standard errors, intervals and the covariance are converted back
to the rpm convention of docs/schemas.md §3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import statsmodels.api as sm
from scipy import stats

from fitting.power_model import PowerModel
from fitting.terms import term_label
from kernel.errors import InputError

#: Fewest points per model term a fit accepts (a fit needs more points than
#: terms; three per term leaves residual degrees of freedom to judge it by).
MIN_POINTS_PER_TERM = 3
#: Fewest points a fit accepts, whatever the term count.
MIN_POINTS = 10


@dataclass(frozen=True, eq=False)
class FitResult:
    """A fitted power model with its statistics (all powers in W, speed in rpm).

    Parameters
    ----------
    terms : tuple of (int, int)
        Exponents (speed, torque) per term.
    coefficients_rpm, std_errors_rpm : numpy.ndarray
        Coefficients and their standard errors (speed in rpm, torque in N m, power in W).
    ci95_rpm : numpy.ndarray
        95 % confidence intervals, shape (n_terms, 2).
    covariance_rpm : numpy.ndarray
        Coefficient covariance, shape (n_terms, n_terms).
    r2 : float
        Unweighted coefficient of determination of P_elec.
    r2_weighted : float
        R^2 of the weighted problem (equals ``r2`` without weights).
    bic : float
        Bayesian information criterion of the (weighted) Gaussian likelihood.
    residuals_w : numpy.ndarray
        Measured minus fitted P_elec per point [W].
    weights : numpy.ndarray
        The weight of each point (mean 1).
    nominal_power_w : float
        Scale for the relative statistics [W].
    condition_number : float
        Condition number of the scaled design.
    studentized : numpy.ndarray
        Externally studentized residual of each point (its weighted residual over
        the residual standard deviation of the fit without it, times
        ``1 / sqrt(1 - h_ii)``; ``h_ii`` the leverage) [-].
    """

    terms: tuple[tuple[int, int], ...]
    coefficients_rpm: np.ndarray
    std_errors_rpm: np.ndarray
    ci95_rpm: np.ndarray
    covariance_rpm: np.ndarray
    r2: float
    r2_weighted: float
    bic: float
    residuals_w: np.ndarray
    weights: np.ndarray
    nominal_power_w: float
    condition_number: float
    studentized: np.ndarray

    @property
    def n_points(self) -> int:
        """Number of points fitted."""
        return int(self.residuals_w.size)

    def residual_stats(self, mask: np.ndarray | None = None) -> dict:
        """Mean, standard deviation and maximum |residual| in W and in % of nominal power."""
        r = self.residuals_w if mask is None else self.residuals_w[mask]
        if r.size == 0:
            return {"n": 0}
        pct = 100.0 / self.nominal_power_w
        mean, std = float(np.mean(r)), float(np.std(r, ddof=1)) if r.size > 1 else 0.0
        max_abs = float(np.max(np.abs(r)))
        return {
            "n": int(r.size),
            "mean_w": mean,
            "std_w": std,
            "max_abs_w": max_abs,
            "rmse_w": float(np.sqrt(np.mean(r**2))),
            "mean_pct_nominal": mean * pct,
            "std_pct_nominal": std * pct,
            "max_abs_pct_nominal": max_abs * pct,
        }

    def normality(self) -> dict:
        """D'Agostino-Pearson K^2 and Jarque-Bera tests of the residuals (H0: normal)."""
        r = self.residuals_w
        out = {"skewness": float(stats.skew(r)), "excess_kurtosis": float(stats.kurtosis(r))}
        if r.size >= 20:  # the K^2 test's kurtosis part needs n >= 20
            k2 = stats.normaltest(r)
            out["dagostino_k2"] = {"statistic": float(k2.statistic), "p_value": float(k2.pvalue)}
        jb = stats.jarque_bera(r)
        out["jarque_bera"] = {"statistic": float(jb.statistic), "p_value": float(jb.pvalue)}
        p_values = [v["p_value"] for v in out.values() if isinstance(v, dict)]
        out["normal_at_5pct"] = bool(min(p_values) >= 0.05)
        return out

    def coefficient_table(self) -> list[dict]:
        """One row per term: label, exponents, coefficient, std error, 95 % interval (rpm)."""
        return [
            {
                "term": term_label(t),
                "speed_exp": t[0],
                "torque_exp": t[1],
                "coef_rpm": float(c),
                "std_error_rpm": float(se),
                "ci95_low_rpm": float(lo),
                "ci95_high_rpm": float(hi),
            }
            for t, c, se, (lo, hi) in zip(
                self.terms, self.coefficients_rpm, self.std_errors_rpm, self.ci95_rpm, strict=True
            )
        ]

    def summary(self, weighting: str, motor: np.ndarray, points: dict) -> dict:
        """The fit's statistics as ``fit_summary.json`` and the model file state them.

        Parameters
        ----------
        weighting : str
            ``quadrant`` (weighted least squares) or ``none`` (ordinary).
        motor : numpy.ndarray of bool
            True for the motor-quadrant points (residuals per quadrant).
        points : dict
            Facts of the points fitted (counts per quadrant), stated after ``n_points``.

        Returns
        -------
        dict
            ``method``, ``weighting``, ``n_points``, ``points``' keys, ``r2``,
            ``r2_weighted``, ``bic``, ``condition_number_scaled_design``,
            ``residuals`` (all, motor, generator), ``normality``, ``coefficients``.
        """
        return {
            "method": "weighted least squares (statsmodels WLS)" if weighting == "quadrant"
            else "ordinary least squares (statsmodels OLS)",
            "weighting": weighting,
            "n_points": self.n_points,
            **points,
            "r2": self.r2,
            "r2_weighted": self.r2_weighted,
            "bic": self.bic,
            "condition_number_scaled_design": self.condition_number,
            "residuals": {"all": self.residual_stats(), "motor": self.residual_stats(motor),
                          "generator": self.residual_stats(~motor)},
            "normality": self.normality(),
            "coefficients": self.coefficient_table(),
        }

    def to_power_model(self, name: str, **metadata) -> PowerModel:
        """The exported :class:`PowerModel` (metadata: domain, masking, statistics, provenance)."""
        return PowerModel(
            terms=self.terms,
            coefficients_rpm=tuple(self.coefficients_rpm),
            covariance_rpm=tuple(map(tuple, self.covariance_rpm)),
            nominal_power_w=self.nominal_power_w,
            name=name,
            **metadata,
        )


def quadrant_weights(quadrant: np.ndarray) -> np.ndarray:
    """Weights that make each quadrant count equally, whatever its point count.

    Each point of quadrant q gets ``N / (n_q * Q)`` (Q quadrants present), so
    every quadrant's weights sum to N / Q and the mean weight is 1. Without
    this, the quadrant with more points (e.g. a denser motor campaign) would
    dominate the fit and the selection.
    """
    quadrant = np.asarray(quadrant)
    labels, inverse, counts = np.unique(quadrant, return_inverse=True, return_counts=True)
    return quadrant.size / (counts[inverse] * labels.size)


def design_scales(speed_rpm: np.ndarray, torque_nm: np.ndarray) -> tuple[float, float]:
    """Scales [rpm], [N m] that bring speed and torque to order one (max |value|)."""
    s = float(np.max(np.abs(speed_rpm))) if np.size(speed_rpm) else 1.0
    t = float(np.max(np.abs(torque_nm))) if np.size(torque_nm) else 1.0
    return (s if s > 0 else 1.0), (t if t > 0 else 1.0)


def design_matrix(terms, speed_rpm, torque_nm, scales: tuple[float, float]) -> np.ndarray:
    """Columns ``(speed/s_w)**i * (torque/s_T)**j`` per term, shape (n_points, n_terms)."""
    x = np.asarray(speed_rpm, dtype=float) / scales[0]
    y = np.asarray(torque_nm, dtype=float) / scales[1]
    return np.column_stack([x**i * y**j for i, j in terms])


def term_scale(terms, scales: tuple[float, float]) -> np.ndarray:
    """Factor turning scaled coefficients into rpm coefficients: 1 / (s_w**i * s_T**j)."""
    return np.array([1.0 / (scales[0] ** i * scales[1] ** j) for i, j in terms])


def check_fit_input(terms, n_points: int, source=None) -> None:
    """Raise :class:`InputError` when there are too few points for ``terms``."""
    needed = max(MIN_POINTS, MIN_POINTS_PER_TERM * len(terms))
    if n_points < needed:
        raise InputError(
            source,
            f"too few operating points: {n_points} for a {len(terms)}-term model",
            expected=f"at least {needed} ({MIN_POINTS_PER_TERM} per term, {MIN_POINTS} minimum)",
        )


def fit_power_model(
    speed_rpm: np.ndarray,
    torque_nm: np.ndarray,
    p_elec_w: np.ndarray,
    terms,
    *,
    weights: np.ndarray | None = None,
    nominal_power_w: float,
    source=None,
) -> FitResult:
    """Fit ``P_elec = sum c_k speed**i_k torque**j_k`` by (weighted) least squares (statsmodels).

    Paper eq. (4) is ``terms = PAPER_TERMS``.

    Parameters
    ----------
    speed_rpm, torque_nm, p_elec_w : numpy.ndarray
        Operating points: drum speed [rpm], drum torque [N m], electrical power [W].
    terms : sequence of (int, int)
        Exponents (speed, torque) per term.
    weights : numpy.ndarray, optional
        Point weights (e.g. :func:`quadrant_weights`); ordinary least squares if None.
    nominal_power_w : float
        Nominal power [W] for the relative statistics.
    source : str or Path, optional
        Named in errors (the store).

    Raises
    ------
    InputError
        Too few points, non-finite values, or a rank-deficient design.
    """
    terms = tuple((int(i), int(j)) for i, j in terms)
    speed = np.asarray(speed_rpm, dtype=float)
    torque = np.asarray(torque_nm, dtype=float)
    p = np.asarray(p_elec_w, dtype=float)
    for name, v in (("speed_rpm", speed), ("torque_nm", torque), ("p_elec_w", p)):
        if not np.all(np.isfinite(v)):
            raise InputError(source, f"{int(np.sum(~np.isfinite(v)))} non-finite values",
                             column=name, expected="finite numbers")
    check_fit_input(terms, p.size, source)
    w = np.ones_like(p) if weights is None else np.asarray(weights, dtype=float)
    scales = design_scales(speed, torque)
    x = design_matrix(terms, speed, torque, scales)
    xw = x * np.sqrt(w)[:, None]
    sv = _full_rank_singular_values(xw, terms, source)
    res = sm.WLS(p, x, weights=w).fit()
    d = term_scale(terms, scales)
    coef = res.params * d
    se = res.bse * d
    ci = res.conf_int(alpha=0.05) * d[:, None]
    cov = res.cov_params() * np.outer(d, d)
    resid = p - x @ res.params
    studentized = _studentized(xw, np.sqrt(w) * resid)
    sst = float(np.sum((p - p.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / sst if sst > 0 else float("nan")
    return FitResult(
        terms=terms,
        coefficients_rpm=np.asarray(coef),
        std_errors_rpm=np.asarray(se),
        ci95_rpm=np.asarray(ci),
        covariance_rpm=np.asarray(cov),
        r2=r2,
        r2_weighted=float(res.rsquared) if weights is not None else r2,
        bic=float(res.bic),
        residuals_w=resid,
        weights=w,
        nominal_power_w=float(nominal_power_w),
        condition_number=float(sv[0] / sv[-1]),
        studentized=studentized,
    )


def _full_rank_singular_values(xw: np.ndarray, terms, source) -> np.ndarray:
    """The singular values of the weighted design; InputError when it is rank deficient."""
    sv = np.linalg.svd(xw, compute_uv=False)
    # numpy's matrix_rank tolerance: sv_max * max(shape) * eps
    rank = int(np.sum(sv > sv[0] * max(xw.shape) * np.finfo(float).eps))
    if rank < len(terms):
        raise InputError(
            source,
            f"rank-deficient design: rank {rank} for {len(terms)} terms "
            f"({', '.join(term_label(t) for t in terms)}); the operating points do not "
            "vary enough in speed and torque to tell these terms apart",
            expected="points spread over speed and torque in both quadrants",
        )
    return sv


def _studentized(xw: np.ndarray, ew: np.ndarray) -> np.ndarray:
    """Externally studentized residuals of a (weighted) least-squares fit.

    ``xw``, ``ew``: the weighted design and residuals (rows times sqrt(weight)).
    ``t_i = e_i / (s_(i) sqrt(1 - h_ii))`` with the leverage ``h_ii`` (diagonal of
    the hat matrix, from a thin QR of the design) and ``s_(i)`` the residual
    standard deviation without point ``i`` (closed form, no refit).
    """
    n, p = xw.shape
    if n - p - 1 <= 0:
        return np.full(n, np.nan)
    q, _ = np.linalg.qr(xw)
    h = np.clip(np.sum(q * q, axis=1), 0.0, 1.0 - 1e-12)
    sse = float(np.sum(ew * ew))
    s2_i = np.maximum((sse - ew * ew / (1.0 - h)) / (n - p - 1), 1e-300)
    return ew / np.sqrt(s2_i * (1.0 - h))


#: family-wise false-alarm probability of the outlier test (Bonferroni over the points)
OUTLIER_ALPHA = 0.05


def outlier_test(fit: FitResult, alpha: float = OUTLIER_ALPHA) -> tuple[np.ndarray, float]:
    """Points whose studentized residual is extreme, and the critical value used.

    Bonferroni outlier test: under the fitted model with normal errors each
    externally studentized residual follows Student's t with ``n - p - 1``
    degrees of freedom; a point is flagged when ``|t_i|`` exceeds the
    ``1 - alpha / (2 n)`` quantile, so a sound campaign of any size has all its
    points pass with probability ``1 - alpha``.

    Returns
    -------
    flagged : numpy.ndarray of bool
        Per point.
    critical : float
        The critical |t| [-].
    """
    n, p = fit.n_points, len(fit.terms)
    dof = n - p - 1
    if dof <= 0:
        return np.zeros(n, bool), float("nan")
    critical = float(stats.t.isf(alpha / (2.0 * n), dof))
    return np.abs(fit.studentized) > critical, critical
