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


@pytest.fixture(scope="session")
def paper_fits(tmp_path_factory):
    """``bench fit --order 1`` and ``--order 2`` of one paper store, run once per session.

    Returns ``{"store": store, 1: (out, printed), 2: (out, printed)}`` (``printed``: what
    the run printed). Read only: a test that changes a folder copies it first.
    """
    import contextlib
    import io

    from drivebench.cli import main

    root = tmp_path_factory.mktemp("paper_fits")
    store = root / "bench_store"
    write_store(synthetic_points(paper_quadratic), store)
    fits = {"store": store}
    for order in (1, 2):
        out = root / f"fit_order_{order}"
        with contextlib.redirect_stdout(io.StringIO()) as printed:
            assert main(["fit", "--store", str(store), "--out", str(out),
                         "--order", str(order)]) == 0
        fits[order] = (out, printed.getvalue())
    return fits
