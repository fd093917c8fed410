"""Fixtures of the fitting tests (helpers live in fit_synthetic.py)."""

from __future__ import annotations

import pytest
from fit_synthetic import paper_quadratic, synthetic_points, write_store


@pytest.fixture
def paper_store(tmp_path):
    """A store of synthetic points around the paper's quadratic (40 W noise)."""
    store = tmp_path / "bench_store"
    write_store(synthetic_points(paper_quadratic), store)
    return store
