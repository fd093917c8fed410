"""Model selection: picks the true order; folds; the paper's extra-terms check."""

import numpy as np
import pytest
from fit_synthetic import PAPER_A, paper_quadratic, synthetic_points

from fitting.extra_terms import extra_terms_check
from fitting.power_fit import quadrant_weights
from fitting.selection import default_candidates, select_model, stratified_folds
from fitting.terms import full_polynomial


def polynomial_truth(order: int, seed: int):
    """A full polynomial of total order ``order`` whose every term is worth
    300..1000 W (random sign) at the rated corner (1500 rpm, 78 N m)."""
    rng = np.random.default_rng(seed)
    terms = full_polynomial(order)
    d = rng.uniform(300, 1000, len(terms)) * rng.choice([-1, 1], len(terms))

    def truth(s, t):
        return sum(dk * (s / 1500) ** i * (t / 78) ** j
                   for dk, (i, j) in zip(d, terms, strict=True))

    return truth


def _select(df, folds=5):
    return select_model(df["speed_rpm"].to_numpy(), df["torque_nm"].to_numpy(),
                        df["p_elec_w"].to_numpy(), df["quadrant"].to_numpy(),
                        quadrant_weights(df["quadrant"].to_numpy()), folds=folds,
                        nominal_power_w=8200.0)


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5, 6])
def test_selection_picks_the_true_order(order):
    # Every term of the truth is worth >= 300 W against 40 W noise, so dropping
    # any order is visible; higher orders only fit noise, and the one-SE rule
    # then prefers the true (smaller) one.
    df = synthetic_points(polynomial_truth(order, seed=order), noise_w=40.0, seed=20 + order)
    sel = _select(df)
    assert sel.chosen.name == f"order {order}", sel.table.to_string()
    assert sel.table["chosen"].sum() == 1
    assert "within one standard error" in sel.reason


def test_selection_picks_eq4_on_the_paper_quadratic():
    # The paper's quadratic has no linear terms: eq. 4 (4 terms) fits as well as the
    # full order 2 (6 terms) and is simpler.
    df = synthetic_points(paper_quadratic, noise_w=40.0, seed=3)
    sel = _select(df)
    assert sel.chosen.name == "paper eq. 4"
    t = sel.table.set_index("candidate")
    # CV RMSE estimates the noise std (40 W) within 10 % (1040 held-out points)
    assert t.at["paper eq. 4", "cv_rmse_w"] == pytest.approx(40.0, rel=0.1)
    assert t.at["order 1", "cv_rmse_w"] > 10 * t.at["paper eq. 4", "cv_rmse_w"]
    assert set(t.index) == {c.name for c in default_candidates()}


def test_folds_are_stratified_per_quadrant():
    q = np.array(["motor"] * 103 + ["generator"] * 41)
    fold = stratified_folds(q, 5, seed=0)
    for k in range(5):
        assert 20 <= np.sum((fold == k) & (q == "motor")) <= 21
        assert 8 <= np.sum((fold == k) & (q == "generator")) <= 9


def test_extra_terms_check_on_a_quadratic_truth():
    # On quadratic data the wide (w^6 T^4) model differs from eq. 4 only by fitted
    # noise: at most ~3 noise std (40 W) at the points.
    df = synthetic_points(paper_quadratic, noise_w=40.0, seed=8)
    w = quadrant_weights(df["quadrant"].to_numpy())
    out = extra_terms_check(df["speed_rpm"], df["torque_nm"], df["p_elec_w"], w,
                            rated_speed_rpm=1500.0, rated_torque_nm=78.0, nominal_power_w=8200.0)
    assert out["model_difference"]["max_abs_w"] < 3 * 40.0
    assert set(out["paper_terms"]) == {"w^2*T^2", "w^4"}
    # the eq. 4 reference sizes are the truth's a1 * 1500^2 and a2 * 78^2 (the
    # issue's 3 % recovery tolerance)
    assert out["a1_at_rated_w"] == pytest.approx(PAPER_A[1] * 1500**2, rel=0.03)
    assert out["a2_at_rated_w"] == pytest.approx(PAPER_A[2] * 78**2, rel=0.03)
    assert len(out["largest_extra_terms_at_rated"]) == 5
