"""The shipped initial guess: it fits the current OCP, and it is an optimum of it."""

from __future__ import annotations

import numpy as np
import pytest

from optimize.model.kite_model import kite_dae
from optimize.model.params import KiteParams
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.solve import initial_guess
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system, system_from_dict


@pytest.fixture(scope="module")
def ocp(paper_ocp):
    return paper_ocp  # the default OCP, shared with other modules (conftest.py)


def test_shipped_guess_fits_the_default_ocp(ocp):
    # fails when the formulation changes without `python -m optimize.solve.initial_guess`
    solution, why = initial_guess.load(ocp)
    assert solution is not None, why
    assert solution.w.size == ocp.layout.n_w and solution.lam_g.size == ocp.layout.n_g


def test_guess_is_refused_for_another_discretization_or_kite():
    coarse = build_ocp(kite_dae(), paper_model(), OcpOptions(Discretization(n_intervals=20)))
    solution, why = initial_guess.load(coarse)
    assert solution is None and "N=40" in why and "N=20" in why
    # 1 kg more mass changes the dynamics residuals at the stored point
    heavier = build_ocp(kite_dae(KiteParams(mass_kg=KiteParams().mass_kg + 1.0)), paper_model(),
                        OcpOptions())
    solution, why = initial_guess.load(heavier)
    assert solution is None and "does not fit" in why


def test_guess_is_accepted_for_its_system_and_refused_for_another():
    # highwind.toml is the guess's system; a copy with only a wider period range has the
    # same constraints g, so only the system hash tells them apart
    system, model = load_system(), paper_model()
    rating = drive_in_force(system, model=model).rating
    own = build_ocp(kite_dae(*system.model_params()), model,
                    system.ocp_options(OcpOptions(), rating), system=system)
    solution, why = initial_guess.load(own)
    assert solution is not None, why
    import tomllib

    data = tomllib.loads(system.text)
    data["bounds"]["period_max_s"] = 30.0
    wider = system_from_dict(data, "wider.toml")
    other = build_ocp(kite_dae(*wider.model_params()), model,
                      wider.ocp_options(OcpOptions(), rating), system=wider)
    solution, why = initial_guess.load(other)
    assert solution is None and "another system" in why


def test_missing_or_damaged_file_is_refused(ocp, tmp_path):
    solution, why = initial_guess.load(ocp, tmp_path / "none.npz")
    assert solution is None and "no stored initial guess" in why
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip archive")
    solution, why = initial_guess.load(ocp, bad)
    assert solution is None and "cannot read" in why and "bad.npz" in why
    partial = tmp_path / "partial.npz"
    np.savez(partial, w=np.zeros(3))
    solution, why = initial_guess.load(ocp, partial)
    assert solution is None and "cannot read" in why


def test_start_from_the_guess_stays_at_its_optimum(ocp, stored_guess_solve):
    # the file holds IPOPT's optimum of elec-lim-7.0 with the paper model: started there,
    # IPOPT must confirm it in a few dozen iterations (the warm start pushes it 1e-2
    # off its active bounds first) and leave the point (scaled
    # variables of order 1) where it is
    stored, _ = initial_guess.load(ocp)
    res = stored_guess_solve  # start(ocp, initial_guess.GUESS_SCENARIO), shared
    assert res.success, res.status
    assert res.start == "stored guess"
    assert [s["stage"] for s in res.stages] == ["stored-guess warm"]
    assert res.iterations <= 30  # the homotopy takes about 220
    assert np.max(np.abs(res.warm.w - stored.w)) < 1e-3
    # issue 4's prototype, electrical with limits at 7 m/s: -558 W, 5.6 s (model
    # differing in details); the same cycle within 5 %
    assert res.avg_p_elec_w == pytest.approx(-558.0, rel=0.05)
    assert res.period_s == pytest.approx(5.6, rel=0.1)
