"""A failed solver call stays a failed call: the starts fall back on it (the homotopy's
inserted weights, the cold retry), and the next call runs on a solver that works.

Was (issue 51, fatrop on the condensed NLP with a 90 degC winding limit): a homotopy stage
that fatrop failed ended where the NLP's derivatives are not finite, carrying its
multipliers to the full layout raised FloatingPointError, and the scenario ended as
"exception: FloatingPointError ... (singular block)" in 29 s, its fallbacks never tried;
and a fatrop solver that had failed a call failed every later call at once (return flag
5, 0 iterations) where a new one converged. The problem here is the exact pendulum
(tests/point_mass_model.py), whose period is the truth.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from point_mass_model import Pendulum, pendulum_formulation, small_angle_guess

from optimize.problem.ocp import assemble, grid_times
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.transcriptions import condensed as condensed_method
from optimize.problem.transcriptions.condensed_multipliers import _complete
from optimize.solve import nlp_solver

N, DEGREE = 20, 3


def _pendulum(solver: str, transcription: str) -> tuple:
    """``(pendulum, ocp, w0, p, bounds)``: the pendulum's OCP, its small-angle start."""
    pendulum = Pendulum()
    form = pendulum_formulation(pendulum)
    ocp = assemble(form, OcpOptions(Discretization(N, DEGREE), solver=SolverOptions(
        solver=solver, transcription=transcription)))
    period = form.scales.period_s
    x, z = small_angle_guess(pendulum, grid_times(ocp, period), period)
    w0 = ocp.pack(x, z[:, 1:], np.zeros((1, N)), np.zeros((2, N * DEGREE)), period)
    p = ocp.params(None, {"p_ctrl_w": 0.0})
    return pendulum, ocp, w0, p, ocp.bounds(drive_limits=False, fix_fictitious=True,
                                            period_s=None)


def test_multipliers_that_do_not_follow_are_refused_by_name_and_quietly():
    grad, lam_x, lam_g = np.ones(2), np.zeros(2), np.zeros(2)
    rows = cols = np.arange(2)
    nan = sp.csc_matrix(np.array([[1.0, np.nan], [0.0, 1.0]]))
    with pytest.raises(FloatingPointError, match="not finite"):
        _complete(grad, nan, lam_x, lam_g, rows, cols)
    singular = sp.csc_matrix(np.array([[1.0, 1.0], [1.0, 1.0]]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # SciPy's MatrixRankWarning reached the user
        with pytest.raises(FloatingPointError, match="singular block"):
            _complete(grad, singular, lam_x, lam_g, rows, cols)
    # a regular block: stationarity at the pinned variables, exactly
    regular = sp.csc_matrix(np.array([[2.0, 0.0], [1.0, 4.0]]))
    out = _complete(grad, regular, lam_x, lam_g, rows, cols)
    assert np.allclose(grad + regular.T @ out + lam_x, 0.0, atol=1e-14)


def test_a_failed_condensed_call_whose_multipliers_do_not_follow_stays_a_failed_call(
        monkeypatch):
    _, ocp, w0, p, bounds = _pendulum("fatrop", "condensed")
    real_call = nlp_solver._call

    def failed(*args):  # the solver ran, and failed
        return dataclasses.replace(real_call(*args), success=False,
                                   status="fatrop return flag 5: failed")

    def not_finite(*_args):
        raise FloatingPointError("the multipliers ...: its terms are not finite")

    monkeypatch.setattr(nlp_solver, "_call", failed)
    monkeypatch.setattr(condensed_method, "to_full", not_finite)
    raw = nlp_solver.run(ocp, w0, p, bounds, warm=False)
    assert not raw.success
    assert raw.status == ("fatrop return flag 5: failed (at its last point the multipliers "
                          "...: its terms are not finite)")
    assert raw.lam_x.shape == (ocp.layout.n_w,) and not raw.lam_x.any()
    assert raw.lam_g.shape == (ocp.layout.n_g,) and not raw.lam_g.any()
    # a converged call whose multipliers do not follow is an error, not a result
    monkeypatch.setattr(nlp_solver, "_call", real_call)
    with pytest.raises(FloatingPointError):
        nlp_solver.run(ocp, w0, p, bounds, warm=False)


@pytest.mark.parametrize("transcription", ["condensed", "collocation"])
def test_a_fatrop_solver_that_failed_a_call_is_made_anew(transcription, monkeypatch):
    pendulum, ocp, w0, p, bounds = _pendulum("fatrop", transcription)
    real_call, seen = nlp_solver._call, []

    def first_fails(nlpsol, *args):
        seen.append(nlpsol)
        raw = real_call(nlpsol, *args)
        return dataclasses.replace(raw, success=False) if len(seen) == 1 else raw

    monkeypatch.setattr(nlp_solver, "_call", first_fails)
    assert not nlp_solver.run(ocp, w0, p, bounds, warm=False).success
    raw = nlp_solver.run(ocp, w0, p, bounds, warm=False)
    assert seen[1] is not seen[0]  # a new solver, not the one that failed
    assert raw.success, raw.status
    assert ocp.unpack(raw.w)["period_s"] == pytest.approx(pendulum.period_s(), rel=1e-5)
    nlp_solver.run(ocp, w0, p, bounds, warm=False)
    assert seen[2] is seen[1]  # a solver that converged is kept


def test_an_ipopt_solver_is_kept_after_a_failed_call(monkeypatch):
    _, ocp, w0, p, bounds = _pendulum("ipopt", "collocation")
    real_call, seen = nlp_solver._call, []

    def failed(nlpsol, *args):
        seen.append(nlpsol)
        return dataclasses.replace(real_call(nlpsol, *args), success=False)

    monkeypatch.setattr(nlp_solver, "_call", failed)
    nlp_solver.run(ocp, w0, p, bounds, warm=False)
    nlp_solver.run(ocp, w0, p, bounds, warm=False)
    assert seen[1] is seen[0]  # IPOPT starts each call afresh: no state to drop


def test_a_sweep_that_fatrop_failed_names_the_option_that_solves_it(tmp_path, monkeypatch,
                                                                    capsys):
    # was: "FAILED ... elec-lim-8.0" and fatrop's status, nothing about --solver ipopt
    from test_sweep import CycleBackend

    from drivebench.cli import main
    from optimize import command
    from optimize.cli import solver_advice

    real = command.run_optimize
    monkeypatch.setattr(command, "run_optimize", lambda request, line, show_progress: real(
        request, line, show_progress, backend=CycleBackend(max_iter=1)))  # every solve fails
    code = main(["optimize", "--wind-grid", "7", "--scenarios", "elec-lim", "--no-claims",
                 "--no-progress", "--workers", "1", "--solver", "fatrop", "--transcription",
                 "condensed", "--out", str(tmp_path / "o")])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1
    at = lines.index("FAILED (status in summary.parquet, never averaged): elec-lim-7.0")
    assert lines[at + 1] == solver_advice("fatrop", "condensed")
    assert lines[at + 1].startswith("fatrop failed them: on this OCP it fails from starts "
                                    "IPOPT solves")
    assert "an interval's Newton solve diverges" in lines[at + 1]
    assert lines[at + 1].endswith("Use --solver ipopt (the default): the paper sweep "
                                  "converges 20/20 with it, on either transcription")
    assert "Newton" not in solver_advice("fatrop", "collocation")
    assert solver_advice("ipopt", "condensed") is None  # IPOPT's failures: nothing to switch
