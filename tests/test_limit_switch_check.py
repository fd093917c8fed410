"""A start whose drive limits differ but do not bind it is checked, not solved again.

The paper kite's drive limits do not bind at 4 m/s: the free kind's optimum there is
the limited kind's too (the paper sweep: 146.47 W drawn by both). The sweep starts the
limited kind from the free kind's optimum at the same speed
(:func:`optimize.service.plan.plan_graph`, stage 1), so that start is a KKT point of its
problem, and its solve costs the convergence check of at most two iterations
(:func:`optimize.solve.solve.at_optimum`). Where the limits bind (7 m/s: the free kind
pulls more torque than the drive's 78 N m), the start lies outside the limited
problem's bounds and is solved as before.
"""

import pytest

from optimize.problem.scenario import Scenario
from optimize.solve.solve import may_solve, solve


@pytest.fixture(scope="module")
def free_at_4(coarse_ocp, coarse_elec_lim):
    return solve(coarse_ocp, Scenario(4.0, "electrical", False), coarse_elec_lim.warm)


def test_a_free_optimum_the_limits_do_not_bind_costs_the_check(coarse_ocp, free_at_4):
    assert free_at_4.success
    limited = solve(coarse_ocp, Scenario(4.0, "electrical", True), free_at_4.warm)
    assert limited.success
    assert [s["stage"] for s in limited.stages] == ["check"]
    assert limited.iterations <= 2
    # the same optimum: the check moves the point by no more than the solver's tolerance
    assert limited.avg_p_elec_w == pytest.approx(free_at_4.avg_p_elec_w, rel=1e-6, abs=1e-4)


def test_a_free_optimum_the_limits_bind_is_solved(coarse_ocp, coarse_elec_lim):
    free = solve(coarse_ocp, Scenario(7.0, "electrical", False), coarse_elec_lim.warm)
    # the limits bind: without them the kite generates more
    assert free.success and free.avg_p_elec_w < coarse_elec_lim.avg_p_elec_w - 1.0
    scenario = Scenario(7.0, "electrical", True)
    p = coarse_ocp.params(scenario.parameters, scenario.weights)
    bounds = coarse_ocp.bounds(drive_limits=True, fix_fictitious=True, period_s=None)
    assert not may_solve(coarse_ocp, free.warm, p, bounds, True)
    # the limited optimum itself: the same problem, checked
    assert may_solve(coarse_ocp, coarse_elec_lim.warm, p, bounds, True)
