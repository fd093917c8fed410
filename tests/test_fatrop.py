"""The stage-wise transcription is the same NLP; fatrop confirms IPOPT's optimum on it."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from system_fixtures import system_for

from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.guess import circular_loop
from optimize.problem.ocp import build_ocp, grid_times, twin
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.solve import nlp_solver
from optimize.solve.result import carry_over
from optimize.solve.solve import solve
from optimize.solve.starts import stored_guess


def _pair(n: int, d: int, drive: dict | None = None):
    opts = OcpOptions(Discretization(n, d), SolverOptions(solver="fatrop"))
    staged = build_ocp(kite_dae(), paper_model(), opts, system=system_for(drive=drive or {}))
    return twin(staged, "ipopt"), staged


def test_stagewise_layout_evaluates_the_same_objective_and_rows():
    general, staged = _pair(3, 3, {"continuous_torque_nm": 60.0, "max_p_elec_w": 9000.0})
    assert general.layout.name == "general" and staged.layout.name == "stagewise"
    x, z, fict = circular_loop(general.dae, general.loop,
                               grid_times(general, general.loop.period_s), 7.0)
    rng = np.random.default_rng(1)
    u = rng.normal(size=(general.layout.i_u.shape[0], 3))
    args = (x, z[:, 1:], u, fict[:, 1:], general.loop.period_s)
    w_g, w_s = general.pack(*args), staged.pack(*args)
    p = general.params(7.0, {"p_elec_w": 1.0}, w_track=0.5, w_fict=0.1, x_ref=x)
    f = [float(ca.Function("f", [o.nlp["x"], o.nlp["p"]], [o.nlp["f"]])(w, p))
         for o, w in ((general, w_g), (staged, w_s))]
    assert f[1] == pytest.approx(f[0], rel=1e-12)
    g_g, g_s = general.constraint_values(w_g, p), staged.constraint_values(w_s, p)
    for name, rows in general.layout.rows.items():
        if name == "period_tie":
            continue
        assert np.allclose(g_s[staged.layout.rows_of(name)], g_g[rows], rtol=1e-12,
                           atol=1e-12), name
    # the rows that tie the stage copies hold at a packed point
    for name in ("continuity", "start_copy"):
        assert np.abs(g_s[staged.layout.rows_of(name)]).max() < 1e-12, name
    # every row is named once; equality flags only where both bound sets say so
    every = np.sort(np.concatenate(list(staged.layout.rows.values())))
    assert np.array_equal(every, np.arange(staged.layout.n_g))
    assert staged.layout.equality[staged.layout.rows_of("continuity")].all()
    assert not staged.layout.equality[staged.layout.rows_of("torque")].any()


@pytest.fixture(scope="module")
def staged():
    """The paper's OCP at the default options, stage-wise for fatrop."""
    return build_ocp(kite_dae(), paper_model(), OcpOptions(solver=SolverOptions(solver="fatrop")),
        system=system_for())


def test_fatrop_confirms_the_stored_optimum_on_the_stage_layout(staged, paper_ocp,
                                                                 stored_guess_solve):
    # the stored guess is IPOPT's optimum of its scenario: carried over to the stage-wise
    # layout, fatrop's warm solve stays on it (independent truth: IPOPT's optimum, warm
    # from the stored guess on the same NLP in the general layout, shared: conftest.py)
    assert twin(staged, "ipopt").options == paper_ocp.options
    scenario = stored_guess.GUESS_SCENARIO
    ref = stored_guess_solve
    assert ref.start == "stored guess"
    res = solve(staged, scenario, stored_guess.load(staged)[0], retry_cold=False)
    assert ref.success and res.success, (ref.status, res.status)
    assert res.status.startswith("fatrop return flag 0")
    assert abs(res.avg_p_elec_w - ref.avg_p_elec_w) < 0.05
    assert abs(res.avg_p_mech_w - ref.avg_p_mech_w) < 0.05
    assert abs(res.period_s - ref.period_s) < 0.01
    stats = nlp_solver.solver(staged, True).stats()
    assert stats["N"] == staged.n_intervals and set(stats["nx"]) == {49}  # X, T, start copy
    assert res.warm.w.size == staged.layout.n_w


def test_stored_guess_is_carried_over_to_the_stage_layout(staged):
    guess, why = stored_guess.load(staged)
    assert guess is not None and "carried over" in why
    general = twin(staged, "ipopt")
    back = carry_over(staged, guess, general)
    stored = stored_guess.load(general)[0]
    assert np.allclose(back.w, stored.w, rtol=0, atol=1e-12)
    p = staged.params(7.0, stored_guess.GUESS_SCENARIO.weights)
    lo, hi = staged.bounds(True, True, None)[2:]
    g = staged.constraint_values(guess.w, p)
    assert np.max(np.maximum(np.maximum(lo - g, g - hi), 0)) < 1e-6


def test_linear_solver_check_names_the_missing_library():
    nlp_solver.check_linear_solver("mumps")
    with pytest.raises(ValueError, match="unknown IPOPT linear solver"):
        nlp_solver.check_linear_solver("ma99")
    try:
        nlp_solver.check_linear_solver("ma57")
    except ValueError as exc:  # no HSL here: the message says what IPOPT looked for
        assert "libhsl.so" in str(exc) and "LD_LIBRARY_PATH" in str(exc)
