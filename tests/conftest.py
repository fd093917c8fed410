"""Fixtures shared by the test modules."""

from __future__ import annotations

import pytest
from ingest_fixtures import make_timeseries_session

from bench.cli import main


@pytest.fixture
def store_and_campaign(tmp_path):
    """A store holding one good session, and a campaign folder with one more session.

    Returns ``(good, camp, store)``: the good session's campaign folder, a campaign folder
    holding session ``bad_01`` (for a test to damage), and the store.
    """
    good = tmp_path / "good"
    make_timeseries_session(good, "good_01", markers=False)
    store = tmp_path / "store"
    assert main(["ingest", str(good), "--store", str(store), "--no-progress"]) == 0
    camp = tmp_path / "camp"
    make_timeseries_session(camp, "bad_01", seed=7)
    return good, camp, store
