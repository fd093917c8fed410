"""The period scan: a scenario solved again with its period held elsewhere, then freed.

A stand-in backend whose objective along the period has two optima (a closed form)
checks that the scan finds and keeps the better one and says so; a real solve on the
paper's coarse OCP checks that a held period is held and that freeing it from there
finds an optimum at least as good as the held one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import minimize
from service_fixtures import Result

from optimize.problem.scenario import Scenario
from optimize.service.builder import Problem
from optimize.service.outcome import ScenarioOutcome
from optimize.service.period_scan import SCAN_GAP, held_periods, scan_periods
from optimize.service.solves import Solves
from optimize.sweep.outputs import resolve_fields, resolve_lines
from optimize.sweep_folder import unchecked_lines

#: the stand-in's period bounds [s], and the wave of its objective: optima at 20 s and
#: 56 s (wavelength 36 s), the one at 56 s better by the slope's 36 W
BOUNDS_S = (5.0, 80.0)
WAVE_S = 36.0


def power_w(period_s: float) -> float:
    """Objective power [W] along the period (negative = generated): two wells."""
    return 50.0 * math.cos(2 * math.pi * (period_s - 20.0) / WAVE_S + math.pi) - 1000.0 \
        - period_s


@dataclass(frozen=True)
class PeriodResult(Result):
    """A stand-in result with its mechanical power [W] and period [s] (the warm start is
    the period)."""

    avg_p_mech_w: float
    period_s: float


def _result(period_s: float) -> PeriodResult:
    p = power_w(period_s)
    return PeriodResult("Solve_Succeeded", True, 5, 1e-3, p, period_s, p, period_s)


class PeriodBackend:
    """Exact stand-in: the free solve descends into the well it starts in; a held solve
    sits at the held period; the cold start lands in the poorer well (20 s)."""

    def build(self, problem):
        return problem.key

    def cold_start(self, ocp, scenario):
        return self.solve(ocp, scenario, 15.0)

    def solve(self, ocp, scenario, warm, period_s=None):
        if period_s is not None:
            return _result(period_s)
        best = minimize(lambda t: power_w(float(t[0])), [warm], bounds=[BOUNDS_S],
                        method="L-BFGS-B", options={"gtol": 1e-12, "ftol": 1e-15})
        return _result(float(best.x[0]))

    def period_bounds(self, ocp):
        return BOUNDS_S

    def check(self, ocp, result, name):
        return None


PROBLEM = Problem(model=None, drive_model=None, options=None, key="period stand-in")
MECH_FREE_10 = Scenario.of_kind("mech-free", 10.0)


def _solved(key=MECH_FREE_10) -> Solves:
    solves = Solves(PROBLEM, backend=PeriodBackend())
    assert solves.solve(key)["success"]
    return solves


def test_held_periods_span_half_to_twice_within_the_bounds():
    # 2^(k/2), k = 1, -1, 2, -2: up to twice and down to half the optimum's period
    assert held_periods(30.0, (1.0, 100.0), 4) == [42.4, 21.2, 60.0, 15.0]
    # clipped into the bounds; none repeated; none within SCAN_GAP of the optimum's own
    got = held_periods(33.5, (20.0, 70.0), 8)
    assert min(got) == 20.0 and max(got) == 67.0 and len(set(got)) == len(got)
    assert got == [39.8, 28.2, 47.4, 23.7, 56.3, 20.0, 67.0]
    assert all(abs(p - 33.5) > SCAN_GAP * 33.5 for p in got)
    assert held_periods(10.0, (9.5, 10.5), 4) == []  # the bounds leave nothing to try
    assert held_periods(30.0, (1.0, 100.0), 1) == [60.0]


def test_the_scan_finds_and_keeps_the_better_optimum():
    key = MECH_FREE_10
    solves = _solved(key)
    first = solves.outcomes[key].result
    assert first.period_s == pytest.approx(20.0, abs=1.0)  # the poorer well
    held = held_periods(first.period_s, BOUNDS_S, 4)
    # T* 2^(1/2), 2^(-1/2), 2, 1/2: only 2 T* (41 s) lies past the ridge at 38 s
    beyond = [p for p in held if p > 20.0 + WAVE_S / 2]
    assert len(beyond) == 1
    scan_periods(solves, [key], 4)
    o = solves.outcomes[key]
    assert o.result.period_s == pytest.approx(56.0, abs=1.0)  # the better well
    assert [r.held_period_s for r in o.resolves] == pytest.approx(held)
    assert sum(r.kept for r in o.resolves) == 1
    fields = resolve_fields(o)
    assert fields["periods_scanned"] == 4
    gain = power_w(first.period_s) - power_w(o.result.period_s)
    assert fields["resolve_gain_w"] == pytest.approx(gain, rel=1e-6) and gain > 30
    source = f"mech-free-10.0 held at {beyond[0]:g} s"
    assert source in fields["resolved_from"]
    lines = resolve_lines([o])
    assert sum("a better optimum, kept" in line for line in lines) == 1
    assert sum("the same optimum" in line for line in lines) == 3
    assert all(line.startswith("mech-free-10.0: period scan; solved from") for line in lines)
    # the kept run is the outcome's last attempt; the record and warm start follow it
    assert o.attempts[-1].source == source
    assert solves.records[key]["period_s"] == pytest.approx(o.result.period_s)
    assert solves.records[key]["warm_from"] == f"10 m/s held at {beyond[0]:g} s"


def test_a_scan_that_finds_nothing_better_keeps_the_first():
    class Better(PeriodBackend):  # the cold start lands in the better well
        def cold_start(self, ocp, scenario):
            return self.solve(ocp, scenario, 60.0)

    key = MECH_FREE_10
    solves = Solves(PROBLEM, backend=Better())
    solves.solve(key)
    first = solves.outcomes[key].result
    scan_periods(solves, [key], 4)  # 80 (the bound), 40 and 28 s: 40 s falls back into it
    o = solves.outcomes[key]
    assert o.result is first and len(o.attempts) == 1
    assert len(o.resolves) == 3 and not any(r.kept for r in o.resolves)
    assert resolve_fields(o)["resolve_gain_w"] == 0.0
    verdicts = sorted(line.rsplit(": ", 1)[1] for line in resolve_lines([o]))
    assert verdicts == ["a poorer optimum, the first kept"] * 2 + ["the same optimum"]


def test_a_failed_held_solve_is_recorded_and_the_first_kept():
    class Failing(PeriodBackend):
        def solve(self, ocp, scenario, warm, period_s=None):
            if period_s is not None:
                return PeriodResult("Infeasible_Problem_Detected", False, 9, 1e-3, math.nan,
                                    warm, math.nan, period_s)
            return super().solve(ocp, scenario, warm)

    key = MECH_FREE_10
    solves = Solves(PROBLEM, backend=Failing())
    solves.solve(key)
    scan_periods(solves, [key], 2)
    o = solves.outcomes[key]
    assert o.result.period_s == pytest.approx(20.0, abs=1.0)
    assert [r.attempt.source for r in o.resolves] == [
        f"mech-free-10.0 held at {p:g} s" for p in held_periods(o.result.period_s, BOUNDS_S, 2)]
    assert all(not r.attempt.success and not r.kept for r in o.resolves)
    assert all("failed (Infeasible_Problem_Detected)" in line for line in resolve_lines([o]))


def test_scanned_kinds_are_not_said_unchecked():
    summary = pd.DataFrame({"kind": ["mech-free", "elec-lim", "elec-lim"],
                            "success": [True, True, True], "periods_scanned": [4, 4, 0]})
    # mech-free has one speed, every one scanned; elec-lim has one unscanned
    assert unchecked_lines(summary) == ["elec-lim: 2 converged wind speeds"]
    assert unchecked_lines(summary.drop(columns="periods_scanned")) == [
        "mech-free: 1 converged wind speed", "elec-lim: 2 converged wind speeds"]


def test_a_scenario_that_failed_is_not_scanned():
    key = MECH_FREE_10
    solves = Solves(PROBLEM, backend=PeriodBackend())
    solves.outcomes[key] = ScenarioOutcome(key, 0, (), None)
    scan_periods(solves, [key], 4)
    assert solves.outcomes[key].resolves == ()


# ----------------------------------------------------------------- a real held solve
def test_a_held_period_is_held_and_freeing_it_finds_an_optimum(coarse_ocp, coarse_mechanical):
    from optimize.solve.solve import solve

    scenario = Scenario(7.0, "mechanical", False)
    t0 = coarse_mechanical.period_s
    held_s = round(1.3 * t0, 3)
    held = solve(coarse_ocp, scenario, coarse_mechanical.warm, period_s=held_s)
    assert held.success and held.period_s == pytest.approx(held_s, rel=1e-9)
    free = solve(coarse_ocp, scenario, held.warm)
    assert free.success
    # freeing the period cannot make the optimum worse than the held one (a
    # relaxation, started from the held optimum), and lands on a stationary period
    assert free.avg_p_mech_w <= held.avg_p_mech_w + 1e-6 * abs(held.avg_p_mech_w)
    assert not np.isclose(free.period_s, held_s, rtol=1e-6)
