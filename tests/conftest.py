"""Fixtures shared by the test modules."""

from __future__ import annotations

import pytest
from ingest_fixtures import make_timeseries_session
from system_fixtures import system_for

from drivebench.cli import main


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


# -- solves shared by the OCP tests: each NLP is built once per session (the OCP object
# caches its solvers) and each shared solve runs once; the results are frozen dataclasses

#: a coarse but converging grid for real solves in the suite
N_COARSE = 10


@pytest.fixture(scope="session")
def paper_ocp():
    """The paper's OCP (paper drive model, default kite) at the default options (IPOPT,
    the discretization of the shipped initial guess)."""
    from optimize.model.kite_model import kite_dae
    from optimize.paper_model import paper_model
    from optimize.problem.ocp import build_ocp
    from optimize.problem.options import OcpOptions

    return build_ocp(kite_dae(), paper_model(), OcpOptions(), system=system_for())


@pytest.fixture(scope="session")
def stored_guess_solve(paper_ocp):
    """IPOPT started from the shipped initial guess on its own scenario (``start``)."""
    from optimize.solve.starts import stored_guess
    from optimize.solve.starts.cold import start

    return start(paper_ocp, stored_guess.GUESS_SCENARIO)


@pytest.fixture(scope="session")
def coarse_ocp():
    """The paper's OCP on the coarse grid (N_COARSE intervals), otherwise default."""
    from optimize.model.kite_model import kite_dae
    from optimize.paper_model import paper_model
    from optimize.problem.ocp import build_ocp
    from optimize.problem.options import Discretization, OcpOptions

    return build_ocp(kite_dae(), paper_model(), OcpOptions(Discretization(n_intervals=N_COARSE)),
        system=system_for())


@pytest.fixture(scope="session")
def coarse_mechanical(coarse_ocp):
    """The homotopy's cold start of the coarse OCP: mechanical power, no drive limits, 7 m/s."""
    from optimize.problem.scenario import Scenario
    from optimize.solve.starts.homotopy import solve_by_homotopy

    return solve_by_homotopy(coarse_ocp, Scenario(7.0, "mechanical", False))


@pytest.fixture(scope="session")
def coarse_elec_lim(coarse_ocp, coarse_mechanical):
    """The coarse OCP's electrical optimum with drive limits at 7 m/s, warm-started from
    ``coarse_mechanical``."""
    from optimize.problem.scenario import Scenario
    from optimize.solve.solve import solve

    return solve(coarse_ocp, Scenario(7.0, "electrical", True), coarse_mechanical.warm)
