"""The condensed transcription (each interval's collocation solved inside the interval)
has the optima of the full Radau collocation.

Truths: the pendulum's period (tests/point_mass_model.py, a closed form), the full
collocation's own optimum of the same NLP (kite and pendulum), the KKT conditions of the
full NLP for the multipliers carried across.
"""

from __future__ import annotations

import logging

import casadi as ca
import numpy as np
import pytest
from point_mass_model import Pendulum, pendulum_formulation, small_angle_guess, solved_pendulum
from system_fixtures import system_for

from drivebench.cli import main
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import assemble, build_ocp, grid_times
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.problem.transcriptions import codegen
from optimize.problem.transcriptions.collocation import full_derivatives
from optimize.problem.transcriptions.condensed import condensed
from optimize.problem.transcriptions.condensed_multipliers import csc
from optimize.solve.solve import solve


@pytest.fixture(scope="module")
def pendulums():
    return {tr: solved_pendulum("ipopt", tr) for tr in ("collocation", "condensed")}


def test_condensed_pendulum_has_the_exact_period_and_the_full_optimum(pendulums):
    pendulum, full_ocp, full, _ = pendulums["collocation"]
    _, ocp, raw, p = pendulums["condensed"]
    assert raw.success, raw.status
    assert ocp.layout.name == "general"  # results stay in the full layout
    period = ocp.unpack(raw.w)["period_s"]
    # Radau collocation of degree 3 on 20 intervals: the period to 1e-5 relative, and
    # the same NLP's optimum as the full transcription to the solver's tolerance
    assert period == pytest.approx(pendulum.period_s(), rel=1e-5)
    assert period == pytest.approx(full_ocp.unpack(full.w)["period_s"], rel=1e-5)
    assert raw.objective == pytest.approx(full.objective, abs=1e-8)
    # the expanded solution satisfies every row of the full NLP (collocation included)
    # to the solver's tolerance (1e-6) on the condensed continuity rows
    bounds = ocp.bounds(drive_limits=False, fix_fictitious=True, period_s=None)
    g = ocp.constraint_values(raw.w, p)
    assert np.max(np.maximum(np.maximum(bounds[2] - g, g - bounds[3]), 0.0)) < 1e-5


def test_multipliers_carried_to_the_full_layout_satisfy_its_kkt_conditions(pendulums):
    _, ocp, raw, p = pendulums["condensed"]
    d = full_derivatives(ocp, "ipopt")
    grad = np.asarray(d["grad_f"](raw.w, p)[1]).ravel()
    jac = csc(d["jac_g"](raw.w, p)[1])
    stationarity = grad + jac.T @ raw.lam_g + raw.lam_x
    assert np.max(np.abs(stationarity)) < 1e-6 * max(1.0, np.max(np.abs(grad)))


def test_condense_and_expand_are_inverse(pendulums):
    _, ocp, raw, p = pendulums["condensed"]
    c = condensed(ocp)
    w_c, p_c = c.condense(raw.w, p)
    # a condensed vector whose gap rows hold exactly: each interval from the end of the
    # one before (a shooting roll-out from the optimum's start and controls)
    it = c.interval
    for k in range(c.n_intervals):
        y, _ = it.solve(w_c[c.i_q[:, k]], p_c[c.i_a[:, k]])
        w_c[c.i_state[:, k + 1]] = np.asarray(y).ravel()[it.parts["x_end"]]
    w_full = c.expand(w_c, p_c)
    back, p_back = c.condense(w_full, p)
    assert np.max(np.abs(back - w_c)) < 1e-12
    assert np.max(np.abs(c.expand(back, p_back) - w_full)) < 1e-12


def test_fatrop_on_the_condensed_nlp_has_the_same_optimum(pendulums):
    _, _, full, _ = pendulums["collocation"]
    pendulum, ocp, raw, _ = solved_pendulum("fatrop", "condensed")
    assert raw.success, raw.status
    assert ocp.unpack(raw.w)["period_s"] == pytest.approx(pendulum.period_s(), rel=1e-5)
    assert raw.objective == pytest.approx(full.objective, abs=1e-8)


def test_condensed_kite_warm_solve_has_the_full_optimum(coarse_mechanical, coarse_elec_lim):
    # the same warm start (the coarse mechanical optimum, the full layout's vectors) on
    # the condensed NLP: the electrical optimum with drive limits to 0.05 W
    n = coarse_mechanical.warm.n_intervals
    ocp = build_ocp(kite_dae(), paper_model(), OcpOptions(
        Discretization(n_intervals=n),
        solver=SolverOptions(transcription="condensed", codegen=False)), system=system_for())
    res = solve(ocp, Scenario(7.0, "electrical", True), coarse_mechanical.warm)
    assert res.success, res.status
    assert res.avg_p_elec_w == pytest.approx(coarse_elec_lim.avg_p_elec_w, abs=0.05)
    assert res.period_s == pytest.approx(coarse_elec_lim.period_s, rel=1e-5)
    assert res.max_violation < 1e-6


@pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")
@pytest.mark.parametrize(("transcription", "libraries"), [
    # the interval's solve, sensitivities and Hessian; the full layout's point functions
    # (the multipliers cross over through them)
    ("condensed", ["interval_hessian", "interval_jacobian", "interval_solve", "point_hess",
                   "point_jac"]),
    ("collocation", ["point_hess", "point_jac"]),  # the Radau point's Jacobian and Hessian
])
def test_compiled_functions_give_the_same_iterations_and_optimum(pendulums, tmp_path,
                                                                 monkeypatch, transcription,
                                                                 libraries):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    _, _, plain, _ = pendulums[transcription]
    _, ocp, raw, _ = solved_pendulum("ipopt", transcription, codegen=True)
    assert raw.success, raw.status
    assert raw.iterations == plain.iterations
    assert raw.objective == pytest.approx(plain.objective, rel=1e-9, abs=1e-12)
    assert np.max(np.abs(raw.w - plain.w)) < 1e-8
    # each compiled once, into the cache by hash
    assert sorted(p.name.rsplit("_", 1)[0] for p in
                  (tmp_path / "drivebench" / "casadi").glob("*.so")) == libraries


def test_without_a_compiler_the_function_stays_and_a_warning_says_so(monkeypatch, caplog):
    monkeypatch.setattr(codegen, "compiler", lambda: None)
    x = ca.SX.sym("x")
    fn = ca.Function("square", [x], [x * x])
    with caplog.at_level(logging.WARNING):
        assert codegen.compiled(fn) is fn
    assert "no C compiler found ($CC, gcc, cc): square runs uncompiled" in caplog.text


def test_a_bad_transcription_is_refused_with_the_choices():
    with pytest.raises(ValueError, match="transcription must be one of collocation, "
                                         "condensed, got 'shooting'"):
        SolverOptions(transcription="shooting")


def test_the_command_line_refuses_a_bad_transcription_with_exit_2(capsys):
    with pytest.raises(SystemExit) as done:
        main(["optimize", "--transcription", "shooting"])
    assert done.value.code == 2
    assert "--transcription: invalid choice: 'shooting'" in capsys.readouterr().err


def test_interval_wise_derivatives_equal_automatic_differentiation():
    # gradient, Jacobian and Lagrangian Hessian assembled interval by interval (implicit
    # function theorem) against CasADi's AD through the Newton solves, at a point off the
    # optimum with every objective term weighted
    pendulum = Pendulum()
    form = pendulum_formulation(pendulum)
    n, degree = 6, 3
    ocp = assemble(form, OcpOptions(Discretization(n, degree), solver=SolverOptions(
        transcription="condensed")))
    c = condensed(ocp)
    fns = ocp.solvers["condensed_derivatives"].functions("ipopt")
    period = form.scales.period_s
    x, z = small_angle_guess(pendulum, grid_times(ocp, period), period)
    w0 = ocp.pack(x, z[:, 1:], 0.1 * np.ones((1, n)), 0.01 * np.ones((2, n * degree)), period)
    p = ocp.params(None, {"p_ctrl_w": 0.7}, w_track=0.3, w_fict=0.2, x_ref=1.01 * x)
    w, p_c = c.condense(w0, p)
    lam = np.random.default_rng(1).standard_normal(c.n_g)
    x_, p_ = c.nlp["x"], c.nlp["p"]
    lag = 0.5 * c.nlp["f"] + ca.dot(ca.DM(lam), c.nlp["g"])
    ad = ca.Function("ad", [x_, p_], [ca.gradient(c.nlp["f"], x_), ca.jacobian(c.nlp["g"], x_),
                                      ca.triu(ca.hessian(lag, x_)[0])])
    grad, jac, hess = ad(w, p_c)
    assert float(ca.norm_inf(fns["grad_f"](w, p_c)[1] - grad)) < 1e-12
    assert float(ca.norm_inf(fns["jac_g"](w, p_c)[1] - jac)) < 1e-12
    assert float(ca.norm_inf(ca.densify(fns["hess_lag"](w, p_c, 0.5, lam)) - ca.densify(hess))
                 ) < 1e-11


def test_the_command_line_hands_transcription_and_codegen_to_the_solver(tmp_path):
    from drivebench.cli import build_parser
    from optimize.command import make_request
    from optimize.sweep_options import SolverChoice, WindGrid

    argv = ["optimize", "--transcription", "condensed", "--codegen"]
    args = build_parser(argv).parse_args(argv)
    choice = SolverChoice(transcription=args.transcription, codegen=args.codegen)
    options = make_request(WindGrid.parse("5:6:0.5", "mech-free"), choice,
                           out=tmp_path / "out").setup.options.solver
    assert (options.transcription, options.codegen) == ("condensed", True)
    default = build_parser(["optimize"]).parse_args(["optimize"])
    assert (default.transcription, default.codegen) == ("collocation", False)
