"""Power fit: recovery of a known truth, statistics, conversions, bad input."""

import numpy as np
import pytest
from fit_synthetic import PAPER_A, paper_quadratic, synthetic_points

from fitting.power_fit import fit_power_model, quadrant_weights
from fitting.terms import PAPER_TERMS, full_polynomial
from kernel.errors import InputError

NOISE_W = 0.016 * 8200  # the paper's residual std: 1.6 % of nominal power


def _fit(df, terms=PAPER_TERMS, weights="quadrant"):
    w = quadrant_weights(df["quadrant"].to_numpy()) if weights == "quadrant" else None
    return fit_power_model(df["speed_rpm"], df["torque_nm"], df["p_elec_w"], terms, weights=w,
                           nominal_power_w=8200.0)


def test_recovers_paper_quadratic():
    # Truth: paper Table I + Gaussian noise of 0.5 % of nominal (41 W), > 500
    # points per quadrant as on the paper's bench. Issue 3 tolerance: a1..a3
    # within 3 %, a0 within 10 %. (a2 is the least determined: its SE is ~1.1 %.)
    df = synthetic_points(paper_quadratic, noise_w=41.0, seed=11)
    fit = _fit(df)
    rel = np.abs(fit.coefficients_rpm / np.array(PAPER_A) - 1)
    assert rel[0] < 0.10
    assert np.all(rel[1:] < 0.03)


def test_statistics_at_the_paper_noise_level():
    # Noise of 1.6 % of nominal (131 W), the paper's residual std.
    df = synthetic_points(paper_quadratic, noise_w=NOISE_W, seed=11)
    fit = _fit(df)
    a = np.array(PAPER_A)
    # each coefficient within 4 standard errors of the truth (a 4-sigma miss has
    # probability 6e-5 per term)
    assert np.all(np.abs(fit.coefficients_rpm - a) < 4 * fit.std_errors_rpm)
    # residual std estimates the noise: n = 1040 gives a ~2 % relative SE; 8 % is 4 SE
    stats = fit.residual_stats()
    assert stats["std_w"] == pytest.approx(NOISE_W, rel=0.08)
    assert stats["std_pct_nominal"] == pytest.approx(1.6, rel=0.08)
    # the paper's "always below 5 %": Gaussian 131 W noise over 1040 points
    # stays below 3.5 sigma = 5.6 % except with probability ~0.4; so check 4.5 sigma
    assert stats["max_abs_pct_nominal"] < 4.5 * 1.6
    assert abs(stats["mean_w"]) < 1e-6  # with a constant term residuals average 0
    assert fit.normality()["normal_at_5pct"]  # Gaussian noise: not rejected (this seed)
    # R^2 ~ 1 - noise variance / variance of P_elec (the fit explains all but the noise)
    expected_r2 = 1 - NOISE_W**2 / np.var(df["p_elec_w"])
    assert fit.r2 == pytest.approx(expected_r2, abs=1e-4)


def test_confidence_intervals_cover_95_percent():
    # Monte Carlo: 200 small campaigns (15 + 15 points), 4 terms each -> 800
    # interval checks; binomial SE of the coverage 0.8 %, so 0.92..0.98 is > 3 SE.
    hits = []
    for seed in range(200):
        df = synthetic_points(paper_quadratic, n_motor=15, n_generator=15, noise_w=NOISE_W,
                              seed=1000 + seed)
        ci = _fit(df, weights=None).ci95_rpm
        hits.append((ci[:, 0] <= PAPER_A) & (np.array(PAPER_A) <= ci[:, 1]))
    assert 0.92 <= np.mean(hits) <= 0.98


def test_normality_check_detects_non_normal_residuals():
    # Uniform noise has excess kurtosis -1.2: with 1040 points both tests reject.
    rng = np.random.default_rng(9)
    df = synthetic_points(paper_quadratic, noise_w=0.0, seed=9)
    df["p_elec_w"] += rng.uniform(-200, 200, len(df))
    assert not _fit(df).normality()["normal_at_5pct"]


def test_recovers_truth_with_small_extra_terms():
    # Truth with small extra terms the quadratic cannot represent, as the paper
    # found them: w^2 T^2 and w^4 each worth 5 W at the rated corner (1500 rpm,
    # 78 N m; w^4 grows to 80 W at 3000 rpm), unequal quadrant sizes. The
    # quadratic part must still come back within the tolerances, with
    # and without quadrant weighting. (With 100 W terms a1, a2 are off by ~10 %:
    # the tolerance holds only for a truth close to the quadratic.)
    def truth(s, t):
        return (paper_quadratic(s, t) + 5.0 * (s / 1500) ** 2 * (t / 78) ** 2
                + 5.0 * (s / 1500) ** 4)

    df = synthetic_points(truth, n_motor=800, n_generator=500, noise_w=41.0, seed=4)
    for weights in ("quadrant", None):
        fit = _fit(df, weights=weights)
        rel = np.abs(fit.coefficients_rpm / np.array(PAPER_A) - 1)
        assert rel[0] < 0.10 and np.all(rel[1:] < 0.03), (weights, rel)


def test_scaled_fit_equals_plain_least_squares():
    # Independent truth: the normal-equation solution and its covariance
    # sigma^2 (X'X)^-1 in plain numpy on the unscaled design; conditioning of the
    # unscaled order-3 design (~1e10) limits agreement to ~1e-5.
    df = synthetic_points(paper_quadratic, noise_w=50.0, seed=2)
    terms = full_polynomial(3)
    fit = _fit(df, terms=terms, weights=None)
    s, t, p = (df[c].to_numpy() for c in ("speed_rpm", "torque_nm", "p_elec_w"))
    x = np.column_stack([s**i * t**j for i, j in terms])
    beta = np.linalg.solve(x.T @ x, x.T @ p)
    r = p - x @ beta
    sigma2 = r @ r / (len(p) - len(terms))
    cov = sigma2 * np.linalg.inv(x.T @ x)
    np.testing.assert_allclose(fit.coefficients_rpm, beta, rtol=1e-5)
    np.testing.assert_allclose(fit.std_errors_rpm, np.sqrt(np.diag(cov)), rtol=1e-5)
    np.testing.assert_allclose(fit.covariance_rpm, cov, rtol=1e-4, atol=1e-30)


def test_quadrant_weights_make_quadrants_equal():
    q = np.array(["motor"] * 300 + ["generator"] * 100)
    w = quadrant_weights(q)
    assert w.mean() == pytest.approx(1.0)
    assert w[q == "motor"].sum() == pytest.approx(w[q == "generator"].sum())


def test_exported_model_evaluates_like_the_fit():
    df = synthetic_points(paper_quadratic, noise_w=30.0, seed=3)
    fit = _fit(df)
    model = fit.to_power_model("t")
    pred = model.p_elec_w(df["speed_rpm"], df["torque_nm"])
    np.testing.assert_allclose(df["p_elec_w"] - pred, fit.residuals_w, atol=1e-6)


def test_too_few_points_refused():
    df = synthetic_points(paper_quadratic, n_motor=4, n_generator=4)
    with pytest.raises(InputError, match="too few operating points: 8"):
        _fit(df)


def test_rank_deficient_design_refused():
    # torque constant: T^2 is a multiple of the constant term
    df = synthetic_points(paper_quadratic)
    df["torque_nm"] = 40.0
    with pytest.raises(InputError, match="rank-deficient design: rank 3 for 4 terms"):
        _fit(df)


def test_nan_refused():
    df = synthetic_points(paper_quadratic)
    df.loc[5, "p_elec_w"] = np.nan
    with pytest.raises(InputError, match="non-finite") as err:
        _fit(df)
    assert err.value.column == "p_elec_w"
