"""The result check of every optimum (optimize/analysis/result_check.py): the Loyd-type
power bound, the collocation error of a finer re-integration and its periodicity; a
converged optimum that fails is a failed scenario; --trust never ends in a traceback."""

from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor
from types import SimpleNamespace

import pandas as pd
import pytest

from drivebench.cli import main
from optimize.analysis import result_check as rc
from optimize.model.params import AeroCoefficients
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.service.builder import Problem
from optimize.service.outcome import Attempt, ScenarioOutcome
from optimize.system.system_file import load_system


def test_power_bound_is_the_largest_aerodynamic_power():
    """The bound equals max over the airspeed v_a of q S (C_R w - C_D v_a), the aerodynamic
    power in the ground frame, found here on a fine grid (rho 1.2, S 2, w 10, C_L 1, C_D 0.1)."""
    import numpy as np

    cl, cd, rho, s, w = 1.0, 0.1, 1.2, 2.0, 10.0
    cr = math.hypot(cl, cd)
    v_a = np.linspace(0.0, 3 * cr / cd * w, 2_000_001)
    best = float(np.max(0.5 * rho * s * v_a**2 * (cr * w - cd * v_a)))
    assert rc.power_bound_w(rho, s, w, cr**3 / cd**2) == pytest.approx(best, rel=1e-9)


def test_force_ratio_of_a_constant_polar():
    """A polar with C_L = cl0 and C_D = cd0 only: the largest ratio is (cl0^2+cd0^2)^1.5/cd0^2."""
    zero = {f.name: 0.0 for f in dataclasses.fields(AeroCoefficients)}
    coeffs = AeroCoefficients(**{**zero, "cl0": 0.8, "cd0": 0.05})
    assert rc.max_force_ratio(coeffs, load_system()) == pytest.approx((0.8**2 + 0.05**2) ** 1.5
                                                               / 0.05**2, rel=1e-12)


def test_a_coarse_optimum_passes(coarse_ocp, coarse_elec_lim):
    check = rc.check_result(coarse_ocp, coarse_elec_lim, "elec-lim-7.0")
    assert check.passed, check.reasons
    assert 0 < check.generated_w < check.power_bound_w
    assert check.defect_scaled < rc.MAX_DEFECT_SCALED
    assert check.periodicity_scaled < rc.MAX_DEFECT_SCALED


def test_an_optimum_above_the_power_bound_is_rejected(coarse_ocp, coarse_elec_lim):
    """The same cycle claiming 30 x the bound: rejected with the bound in the reason."""
    bound = rc.check_result(coarse_ocp, coarse_elec_lim, "x").power_bound_w
    fake = dataclasses.replace(coarse_elec_lim, avg_p_mech_w=-30 * bound)
    check = rc.check_result(coarse_ocp, fake, "elec-lim-7.0")
    assert not check.passed
    assert "Loyd-type bound" in check.verdict() and "mesh 10 intervals" in check.verdict()
    out = ScenarioOutcome(Scenario.of_kind("elec-lim", 7.0), 0,
                          (Attempt(None, "Solve_Succeeded", False, 5, 0.1, check),), fake)
    assert not out.success and out.status == "Solve_Succeeded"


def test_two_interval_degree_one_optimum_is_failed_and_reported(tmp_path, capsys):
    """The case that reported 2947 W generated at 1 m/s: failed by the result check (also
    when solved again on 4 and 8 intervals, the last retry), the files written (every
    trajectory column, no row), and the report lists its status."""
    out = tmp_path / "opt"
    code = main(["optimize", "--wind-grid", "1", "--scenarios", "elec-lim", "--intervals", "2",
                 "--degree", "1", "--no-claims", "--workers", "1", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 1, text
    summary = pd.read_parquet(out / "summary.parquet")
    row = summary.iloc[0]
    assert not row["success"] and row["status"] == "Solve_Succeeded"
    assert "Loyd-type bound" in row["result_check"]
    assert "mesh 8 intervals x degree 1 (below the documented minimum" in row["result_check"]
    assert row["warm_source"] == "elec-lim-1.0 on 8 intervals" and row["n_intervals"] == 8
    assert math.isnan(row["avg_p_elec_w"])
    traj = pd.read_parquet(out / "trajectories.parquet")
    assert len(traj) == 0 and {"time_s", "l_m", "p_elec_w", "speed_rpm"} <= set(traj.columns)
    report = tmp_path / "report.html"
    assert main(["report", "--store", str(tmp_path / "none"), "--fit", str(tmp_path / "none"),
                 "--optimize", str(out), "--out", str(report)]) == 0
    html = report.read_text()
    assert 'id="failed-scenarios"' in html and "elec-lim-1.0" in html
    assert "Solve_Succeeded" in html and "Loyd-type bound" in html


def test_trust_simulation_that_cannot_finish_is_a_finding(coarse_ocp, coarse_elec_lim,
                                                              monkeypatch):
    """CVODES giving up (CV_TOO_MUCH_WORK) is a failed simulation check, not a traceback."""
    from optimize.paper_model import paper_model
    from optimize.sweep import trust

    def give_up(ocp, result):
        raise RuntimeError("Error in Function::call for 'interval' [IntegratorInternal]:\n"
                           "CVODES returned \"CV_TOO_MUCH_WORK\"")

    monkeypatch.setattr(trust, "simulation_check", give_up)
    problem = Problem.for_system(coarse_ocp.system, paper_model(),
                                 OcpOptions(Discretization(n_intervals=coarse_ocp.n_intervals)))
    outcome = ScenarioOutcome(Scenario.of_kind("elec-lim", 7.0), 0,
                              (Attempt(None, "Solve_Succeeded", True, 5, 0.1),),
                              coarse_elec_lim)
    with ThreadPoolExecutor(1) as pool:  # no mesh check: 7 m/s is not the middle speed
        found = trust.run_trust_checks(problem, [outcome], (6.0, 8.0, 9.0),
                                       SimpleNamespace(executor=pool, channel=None))
    (sim,) = found["simulation"]
    assert sim["verdict"].startswith("failed: the simulation could not finish")
    assert "CV_TOO_MUCH_WORK" in sim["verdict"]
    assert any("CV_TOO_MUCH_WORK" in line for line in found["lines"])
