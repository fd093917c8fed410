"""Term lists: counts by hand, labels."""

import pytest

from fitting.terms import PAPER_TERMS, full_polynomial, paper_space, term_label


@pytest.mark.parametrize("order", range(1, 7))
def test_full_polynomial_has_all_monomials(order):
    terms = full_polynomial(order)
    # number of monomials of total degree <= N in two variables: (N+1)(N+2)/2
    assert len(terms) == (order + 1) * (order + 2) // 2
    assert len(set(terms)) == len(terms)
    assert all(i + j <= order and i >= 0 and j >= 0 for i, j in terms)
    assert terms[0] == (0, 0)


def test_paper_space_and_eq4():
    space = paper_space()
    assert len(space) == 7 * 5  # speed^0..6 x torque^0..4
    assert (6, 4) in space and (2, 2) in space and (4, 0) in space and (7, 0) not in space
    assert set(PAPER_TERMS) <= set(space)
    assert set(PAPER_TERMS) <= set(full_polynomial(2))


@pytest.mark.parametrize("order", [0, 7, -1])
def test_order_outside_range_refused(order):
    with pytest.raises(ValueError, match="outside 1..6"):
        full_polynomial(order)


def test_labels():
    assert [term_label(t) for t in PAPER_TERMS] == ["1", "w^2", "T^2", "w*T"]
    assert term_label((4, 3)) == "w^4*T^3"
