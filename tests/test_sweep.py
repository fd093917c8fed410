"""Sweep planning, chain execution and executors, driven by a cheap exact stand-in solver.

The stand-in replaces the kite OCP by a problem with a known answer: for a
scenario at wind speed w, solve ``x**3 + x = w`` by Newton's method (unique
real root, x increasing in w). Its "average electrical power" is
``P(w) = SCALE * (x(w_c) - x(w))`` with a chosen cut-in speed ``w_c`` per
kind, so the drive consumes below w_c and generates above it: the cut-in
search must recover w_c. A cold start begins Newton at x = 0, a warm start at
the source's root, so warm starts need fewer iterations, as with IPOPT.
"""

from __future__ import annotations

import dataclasses
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import pytest
from service_fixtures import Result

from kernel.errors import InputError
from optimize.problem.scenario import Scenario, scenario_name
from optimize.service import ChainTask, Problem, Solves, SweepTasks, run_chain, run_sweep
from optimize.service.cut_in import find_cut_in
from optimize.service.executors import ExecutorHandle, QueueChannel, open_executor, run_tasks
from optimize.service.plan import (
    NEAR_START_COST,
    OBJECTIVE_SWITCH_COST,
    chain_steps,
    continuation_order,
    lead_kinds,
    middle_index,
    plan_graph,
    start_cost,
)
from optimize.service.solves import MAX_WARM_ATTEMPTS
from optimize.sweep_options import WindGrid, parse_kinds, parse_wind_grid

CUT_IN_M_S = {"elec-lim": 4.8, "mech-lim": 5.5, "elec-free": 4.6, "mech-free": 20.0}
SCALE_W = 1000.0
WINDS = (4.0, 5.5, 7.0, 8.5, 10.0)
KINDS = ("elec-lim", "elec-free", "mech-lim", "mech-free")


def exact_root(w: float) -> float:
    """Real root of x**3 + x - w, independently of Newton (numpy companion matrix)."""
    roots = np.roots([1.0, 0.0, 1.0, -w])
    return float(roots[np.argmin(np.abs(roots.imag))].real)


@dataclass(frozen=True)
class NewtonBackend:
    """Exact stand-in solver; ``fail_warm`` scenarios fail every warm start (not cold)."""

    fail_warm: tuple[str, ...] = ()
    max_iter: int = 100

    def build(self, problem: Problem) -> str:
        return problem.key

    def _newton(self, kind: str, w: float, x: float) -> Result:
        for it in range(1, self.max_iter + 1):
            step = (x**3 + x - w) / (3 * x**2 + 1)
            x -= step
            if abs(step) < 1e-13:
                p = SCALE_W * (exact_root(CUT_IN_M_S[kind]) - x)
                return Result("Solve_Succeeded", True, it, 1e-3, p, x)
        return Result("Maximum_Iterations_Exceeded", False, self.max_iter, 1e-3, math.nan, x)

    def solve(self, ocp: str, scenario: Scenario, warm: float) -> Result:
        kind, w = scenario.kind, scenario.wind_speed_m_s
        if scenario_name(kind, w) in self.fail_warm:
            return Result("Infeasible_Problem_Detected", False, 7, 1e-3, math.nan, warm)
        return self._newton(kind, w, warm)

    def cold_start(self, ocp: str, scenario: Scenario) -> Result:
        kind, w = scenario.kind, scenario.wind_speed_m_s
        return self._newton(kind, w, 0.0)

    def check(self, ocp, result, name):
        return None  # an exact stand-in solver: nothing to check


PROBLEM = Problem(model=None, drive_model=None, options=None, key="stand-in")


# ----------------------------------------------------------------- wind grid and kinds
def test_wind_grid_includes_both_endpoints():
    # the paper's grid: 4 to 10 m/s in steps of 1.5 (section V), 5 speeds
    assert parse_wind_grid("4:10:1.5") == WINDS
    assert parse_wind_grid(" 7 ") == (7.0,)
    assert parse_wind_grid("7,4,5.5") == (4.0, 5.5, 7.0)
    # 0.1 steps accumulate float error; values must still be exact to 1e-9
    grid = parse_wind_grid("4:5:0.1")
    assert len(grid) == 11 and grid[-1] == 5.0
    assert np.allclose(grid, np.linspace(4, 5, 11), rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "spec, fragment",
    [
        ("", "empty"),
        ("4:10", "2 fields"),
        ("4:10:0", "step 0 is not > 0"),
        ("10:4:1.5", "below start"),
        ("4:10:1.4", "whole number of steps"),
        ("4:x:1", "'x' is not a number"),
        ("-1,4", "is not > 0"),
        ("4,4", "appears twice"),
        ("4:nan:1", "not finite"),
        ("1:1000:1", "more than"),
    ],
)
def test_bad_wind_grid_is_an_input_error(spec, fragment):
    with pytest.raises(InputError) as err:
        parse_wind_grid(spec)
    assert fragment in str(err.value) and "--wind-grid" in str(err.value)


def test_parse_kinds():
    assert parse_kinds("mech-free, elec-lim") == ("mech-free", "elec-lim")
    for bad in ("", "elec", "elec-lim,elec-lim"):
        with pytest.raises(InputError, match="--scenarios"):
            parse_kinds(bad)


# ----------------------------------------------------------------- planning
def test_continuation_goes_outwards_from_the_middle():
    assert continuation_order(WINDS) == [
        (7.0, None),
        (8.5, 7.0),
        (5.5, 7.0),
        (10.0, 8.5),
        (4.0, 5.5),
    ]
    # even count: lower middle, still every speed once from its inner neighbour
    assert continuation_order((1.0, 2.0, 3.0, 4.0)) == [
        (2.0, None),
        (3.0, 2.0),
        (1.0, 2.0),
        (4.0, 3.0),
    ]


def _check_graph(steps, winds, kinds):
    """Every scenario once; one cold start; sources planned earlier and shallower; no
    start farther than a wind step and a limit switch but the switch of objective at the
    seed's speed; at most 2 deep after the first solve of each objective on up to five
    speeds, else one more per further wind step each way from the middle. Stage 1: every
    kind that is not its objective's lead, each speed from the lead at the same speed
    (one deeper), the lead at the neighbouring speeds as fallbacks."""
    assert sorted(s.name for s in steps) == sorted(scenario_name(k, w) for k in kinds
                                                   for w in winds)
    leads = lead_kinds(kinds)
    assert [s.stage for s in steps] == sorted(s.stage for s in steps)
    assert {s.scenario.kind for s in steps if s.stage == 0} == set(leads)
    depth, by_scenario = {}, {}
    for step in steps:
        sources = [s for s in (step.warm_from, *step.fallbacks) if s is not None]
        assert all(s in depth for s in sources)  # planned earlier
        assert step.warm_from not in step.fallbacks
        own = step.scenario
        if step.stage == 1:
            src = by_scenario[step.warm_from]
            assert src.scenario.kind in leads and src.stage == 0
            assert src.scenario.wind_speed_m_s == own.wind_speed_m_s
            assert src.scenario.objective == own.objective and step.depth == src.depth + 1
            assert all(f.kind == src.scenario.kind for f in step.fallbacks)
            assert all(abs(winds.index(f.wind_speed_m_s) - winds.index(own.wind_speed_m_s))
                       == 1 for f in step.fallbacks)
        else:
            assert all(depth[s] < step.depth for s in sources)
            assert (step.depth == 0) == (step.warm_from is None)
        if step.warm_from is not None and step.stage == 0:
            src = by_scenario[step.warm_from].scenario
            cost = start_cost(own, src, abs(winds.index(own.wind_speed_m_s)
                                            - winds.index(src.wind_speed_m_s)))
            switch = (by_scenario[src].depth == 0
                      and src.wind_speed_m_s == own.wind_speed_m_s)
            assert cost <= (OBJECTIVE_SWITCH_COST if switch else NEAR_START_COST)
        depth[step.scenario] = step.depth
        by_scenario[step.scenario] = step
    objectives = len({k[:4] for k in kinds})
    assert [s.depth for s in steps].count(0) == 1
    lead_depth = max(s.depth for s in steps if s.stage == 0)
    assert lead_depth <= max(2, len(winds) - middle_index(winds) - 1) + objectives - 1
    assert max(depth.values()) <= lead_depth + 1
    return depth


def test_the_paper_sweep_is_a_graph_with_one_cold_start():
    steps = plan_graph(WINDS, KINDS)
    depth = _check_graph(steps, WINDS, KINDS)
    assert [s.name for s in steps if s.depth == 0] == ["elec-free-7.0"]
    # depth 1: one wind step or one limit switch from the seed, and the other objective
    # at the seed's speed (a switch of objective, no cold start of its own)
    assert {s.name: s.warm_from.name for s in steps if s.depth == 1 and s.stage == 0} == {
        "elec-free-5.5": "elec-free-7.0", "elec-free-8.5": "elec-free-7.0",
        "mech-free-7.0": "elec-free-7.0"}
    by_name = {s.name: s for s in steps}
    # then from the nearest: a wind step of the same kind
    assert by_name["elec-free-4.0"].warm_from.name == "elec-free-5.5"
    assert by_name["mech-free-8.5"].warm_from.name == "mech-free-7.0"
    # stage 1, after the lead kinds' re-solves: the drive limits tightened at the same speed
    assert by_name["elec-lim-7.0"].warm_from.name == "elec-free-7.0"
    assert [f.name for f in by_name["elec-lim-5.5"].fallbacks] == ["elec-free-4.0",
                                                                   "elec-free-7.0"]
    assert by_name["mech-lim-10.0"].warm_from.name == "mech-free-10.0"
    assert [s.stage for s in steps].count(1) == 10
    assert sum(d == 3 for d in depth.values()) == 6 and max(depth.values()) == 4
    # any grid and selection: near starts, one cold start
    for winds, kinds in (((4.0, 5.0, 6.0, 7.0), ("mech-free",)), ((7.0,), KINDS),
                         (tuple(4.0 + i for i in range(13)), ("elec-free", "mech-lim"))):
        steps = plan_graph(winds, kinds)
        _check_graph(steps, winds, kinds)


def test_a_long_grid_starts_each_scenario_from_a_near_one():
    # make demo's grid: 8 speeds, seeds at 8.5 m/s; 14.5 m/s starts from 13, not from 10
    winds = tuple(4.0 + 1.5 * i for i in range(8))
    by_name = {s.name: s for s in plan_graph(winds, KINDS)}
    assert by_name["elec-free-14.5"].warm_from.name == "elec-free-13.0"
    assert by_name["mech-free-13.0"].warm_from.name == "mech-free-11.5"
    assert by_name["mech-lim-13.0"].warm_from.name == "mech-free-13.0"
    assert by_name["elec-lim-4.0"].warm_from.name == "elec-free-4.0"
    # 8.5 -> 10 -> 11.5 -> 13 -> 14.5, one more after the switch of objective, and
    # one more for the limit switch of stage 1
    assert max(s.depth for s in by_name.values() if s.scenario.kind == "elec-free") == 4
    assert max(s.depth for s in by_name.values() if s.scenario.kind == "elec-lim") == 5
    assert max(s.depth for s in by_name.values()) == 6


# ----------------------------------------------------------------- running the sweep
def _sweep(kinds=KINDS, cut_in_kinds=(), backend=None, workers=2, problem=PROBLEM):
    """The sweep of ``kinds`` on WINDS on a thread pool (the stand-in solver by default)."""
    tasks = SweepTasks(problem, plan_graph(WINDS, kinds), cut_in_kinds=cut_in_kinds,
                       backend=backend or NewtonBackend(), selected=kinds)
    with ThreadPoolExecutor(workers) as ex:
        return run_sweep(tasks, ExecutorHandle(ex, QueueChannel(), "threads", workers),
                         show_progress=False)


def test_sweep_solves_every_scenario_exactly_with_cheap_warm_starts():
    result = _sweep(cut_in_kinds=("elec-lim", "mech-lim"))
    assert len(result.outcomes) == 20 and all(o.success for o in result.outcomes)
    for o in result.outcomes:
        # Newton converges quadratically: 1e-9 relative is far above its round-off
        want = SCALE_W * (exact_root(CUT_IN_M_S[o.kind]) - exact_root(o.wind_speed_m_s))
        assert o.result.avg_p_elec_w == pytest.approx(want, rel=1e-9, abs=1e-9)
    cold = [o for o in result.outcomes if o.warm_source == "cold start"]
    assert [o.name for o in cold] == ["elec-free-7.0"]  # one per sweep
    # the depth column says where each start came from: the plan's, as every start converged
    planned = {s.name: s.depth for s in plan_graph(WINDS, KINDS)}
    assert {o.name: o.depth for o in result.outcomes} == planned
    warm_iters = [o.attempts[-1].iterations for o in result.outcomes if o not in cold]
    assert max(warm_iters) < min(o.attempts[-1].iterations for o in cold)
    # one task per step, then one per kind for its re-solves and cut-in search
    assert len(result.chains) == 24 and {o.chain for o in result.outcomes} == set(range(20))


def test_cut_in_bisection_finds_the_known_crossing():
    result = _sweep(cut_in_kinds=KINDS)
    found = {c.kind: c for c in result.cut_ins}
    for kind in ("elec-lim", "mech-lim", "elec-free"):
        c = found[kind]
        assert c.status == "found"
        assert c.bracket_hi_m_s - c.bracket_lo_m_s <= 0.05
        assert c.bracket_lo_m_s <= CUT_IN_M_S[kind] <= c.bracket_hi_m_s
        # interpolation inside a 0.05 m/s bracket of a smooth curve: far better than the width
        assert c.cut_in_m_s == pytest.approx(CUT_IN_M_S[kind], abs=0.01)
        # 1.5 m/s bracket halved to <= 0.05 m/s: ceil(log2(30)) = 5 probes
        assert len(c.probes) == 5
    # mech-free "cuts in" at 20 m/s: it consumes on the whole grid
    assert found["mech-free"].status == "never generates on the grid"
    assert math.isnan(found["mech-free"].cut_in_m_s)


def test_cut_in_edge_cases():
    solves = Solves(PROBLEM, backend=NewtonBackend())
    grid = {w: SCALE_W * (exact_root(3.0) - exact_root(w)) for w in WINDS}
    assert find_cut_in(solves, "elec-lim", grid).status == (
        "generates at every converged grid speed"
    )
    assert find_cut_in(solves, "elec-lim", {4.0: grid[4.0]}).status == (
        "too few converged grid speeds"
    )
    assert not solves.records  # decided from the grid alone, nothing solved


@dataclass(frozen=True)
class StoredGuessResult(Result):
    start: str = "stored guess"  # as optimize.solve.starts.cold.start marks from the shipped guess


class StoredGuessBackend(NewtonBackend):
    def cold_start(self, ocp: str, scenario: Scenario) -> Result:
        kind, w = scenario.kind, scenario.wind_speed_m_s
        return StoredGuessResult(*dataclasses.astuple(self._newton(kind, w, 0.0)))


def _solve_one(backend, sources=(), solved=()):
    """The outcome of mech-free at 10 m/s from ``sources`` after solving ``solved`` cold."""
    solves = Solves(PROBLEM, backend=backend)
    for kind, wind in solved:
        solves.solve(Scenario.of_kind(kind, wind), sources=[])
    scenario = Scenario.of_kind("mech-free", 10.0)
    solves.solve(scenario, sources=[Scenario.of_kind(k, w) for k, w in sources])
    return solves.outcomes[scenario]


def test_warm_source_tells_a_stored_guess_start_from_a_homotopy():
    out = _solve_one(StoredGuessBackend())
    assert [a.source for a in out.attempts] == [None] and out.success
    assert out.warm_source == "stored guess"
    assert _solve_one(NewtonBackend()).warm_source == "cold start"


def test_failed_warm_start_retries_fallback_then_cold_start():
    sources = [("mech-free", 8.5), ("mech-lim", 10.0), ("mech-lim", 8.5)]
    solved = [("mech-free", 8.5), ("mech-lim", 10.0)]
    # primary converges
    ok = _solve_one(NewtonBackend(fail_warm=()), sources, solved)
    assert [a.source for a in ok.attempts] == ["mech-free-8.5"] and ok.success
    # every warm start fails: MAX_WARM_ATTEMPTS warm tries, then one cold start that works
    backend = NewtonBackend(fail_warm=("mech-free-10.0",))
    out = _solve_one(backend, sources, solved)
    assert [a.source for a in out.attempts] == ["mech-free-8.5", "mech-lim-10.0", None]
    assert MAX_WARM_ATTEMPTS == 2
    assert out.success and out.warm_source == "cold start"
    assert out.result.warm == pytest.approx(exact_root(10.0), rel=1e-12)
    # a source that is not available (not solved, or its own solve failed) is skipped
    out = _solve_one(backend, sources, [("mech-lim", 10.0)])
    assert [a.source for a in out.attempts] == ["mech-lim-10.0", None]


def test_failure_is_reported_not_dropped():
    # Newton capped at 3 iterations: the cold start (from x = 0) cannot converge at 7 m/s
    out = _sweep(("elec-lim",), backend=NewtonBackend(max_iter=3))
    assert len(out.outcomes) == 5
    assert not any(o.success for o in out.outcomes)
    assert {o.status for o in out.outcomes} == {"Maximum_Iterations_Exceeded"}


# ----------------------------------------------------------------- executors
def _check_sweep(result):
    assert len(result.outcomes) == 20 and all(o.success for o in result.outcomes)
    assert [o.name for o in result.outcomes[:5]] == [scenario_name("elec-lim", w) for w in WINDS]
    assert {c.kind for c in result.cut_ins} == {"elec-lim", "mech-lim"}


def _chains(kinds, cut_in_kinds=()):
    """One chain task per kind along WINDS (as ``bench size`` runs them)."""
    return [ChainTask(PROBLEM, chain_steps((k,), WINDS), i, backend=NewtonBackend(),
                      cut_in_kinds=tuple(c for c in cut_in_kinds if c == k))
            for i, k in enumerate(kinds)]


def test_sweep_on_a_thread_pool_with_progress_events():
    _check_sweep(_sweep(cut_in_kinds=("elec-lim", "mech-lim")))


def test_sweep_on_a_local_dask_cluster():
    # open_executor(scheduler=ADDRESS) connects its own client to a running cluster,
    # as bench optimize --scheduler does; in-process workers see this test module
    distributed = pytest.importorskip("distributed")

    tasks = SweepTasks(PROBLEM, plan_graph(WINDS, KINDS), cut_in_kinds=("elec-lim", "mech-lim"),
                       backend=NewtonBackend(), selected=KINDS)
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
        ) as cluster,
        open_executor(scheduler=cluster.scheduler_address) as handle,
    ):
        assert handle.n_workers == 2 and handle.description.startswith("dask scheduler")
        seen: list[dict] = []
        futures = run_tasks(handle.executor, run_chain, _chains(KINDS, ("elec-lim", "mech-lim")),
                            handle.channel, seen.append)
        assert all(f.exception() is None for f in futures)
        # 20 grid solve events, the probes' and 2 cut-in events came back through the Dask queue
        solved = [e for e in seen if "role" in e and "attempt" not in e]  # the solves' records
        assert len([e for e in solved if e["role"] == "grid"]) == 20
        assert {e["role"] for e in solved} == {"grid", "cut-in"}
        # and each solver run was announced through the same queue
        assert {e["role"] for e in seen if "attempt" in e} == {"grid", "cut-in"}
        assert sorted(e["cut_in"] for e in seen if "cut_in" in e) == ["elec-lim", "mech-lim"]
        result = run_sweep(tasks, handle, show_progress=False)
    _check_sweep(result)


def test_process_pool_executor_runs_chains_with_progress():
    # the real default executor: spawned processes and a manager-queue channel
    tasks = _chains(("elec-lim", "mech-lim"))
    seen: list[dict] = []
    with open_executor(workers=2) as handle:
        assert handle.description == "process pool, 2 workers"
        futures = run_tasks(handle.executor, run_chain, tasks, handle.channel, seen.append)
    outs = [f.result() for f in futures]
    records = [e for e in seen if "attempt" not in e]  # one per solve; the others announce
    assert sorted(e["name"] for e in records) == sorted(s.name for t in tasks for s in t.steps)
    assert all(int(o.worker.rsplit(":", 1)[1]) != os.getpid() for o in outs)  # ran in children
    assert all(o.success for c in outs for o in c.outcomes)
    with pytest.raises(InputError, match="--workers 0"), open_executor(workers=0):
        pass


# ----------------------------------------------------------------- the command line
def test_cli_rejects_bad_input_with_exit_code_2(tmp_path, capsys):
    from drivebench.cli import main

    out = str(tmp_path / "out")
    assert main(["optimize", "--wind-grid", "4:10:1.4", "--out", out]) == 2
    assert "--wind-grid '4:10:1.4'" in capsys.readouterr().err
    assert main(["optimize", "--scenarios", "elec-lim,bogus", "--out", out]) == 2
    assert "unknown kind 'bogus'" in capsys.readouterr().err
    missing = tmp_path / "nope.json"
    assert main(["optimize", "--drive-model", str(missing), "--out", out]) == 2
    assert f"{missing}: file not found" in capsys.readouterr().err
    assert main(["optimize", "--intervals", "1", "--out", out]) == 2
    (tmp_path / "afile").write_text("x")
    assert main(["optimize", "--out", str(tmp_path / "afile")]) == 2
    assert "is not a folder" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # nothing written on bad input


def test_request_falls_back_to_the_paper_model(tmp_path):
    from fitting.model_file import save_power_model
    from optimize.command import make_request
    from optimize.paper_model import PAPER_MODEL_PATH, paper_model

    def request(fit):
        return make_request(WindGrid.parse("5:6:0.5", "mech-free"),
                            fit_default=fit, out=tmp_path / "out")

    req = request(tmp_path / "fit_out" / "power_model.json")
    assert req.setup.resolution.model_path == PAPER_MODEL_PATH
    assert "shipped paper model" in req.model_note
    assert req.grid == WindGrid((5.0, 5.5, 6.0), ("mech-free",))
    assert req.setup.options.discretization.n_intervals == 40
    assert req.setup.options.discretization.degree == 4 and req.claims
    # a fit in fit_out/ takes precedence when it exists
    fit = tmp_path / "fit_out" / "power_model.json"
    fit.parent.mkdir()
    save_power_model(paper_model(), fit)
    assert request(fit).setup.resolution.model_path == fit


@dataclass(frozen=True)
class CycleResult(Result):
    """Stand-in result with the cycle fields the output files need."""

    period_s: float = 5.0
    avg_p_mech_w: float = 0.0
    trajectory: object = None


@dataclass(frozen=True)
class CycleBackend(NewtonBackend):
    """NewtonBackend whose results carry a period and a 3-point trajectory."""

    def _newton(self, kind: str, w: float, x: float) -> CycleResult:
        import pandas as pd

        r = super()._newton(kind, w, x)
        traj = pd.DataFrame(
            {
                "time_s": [1.0, 2.0, 3.0],
                "weight": [1 / 3, 1 / 3, 1 / 3],  # quadrature weights, as real trajectories carry
                "l_m": [100.0, 120.0, 110.0],
                "ddl_m_s2": [0.5 * w, -1.0, 0.0],
                "speed_rpm": [-100.0 * w, 50.0, 80.0 * w],
                "torque_nm": [10.0 * w, 5.0, 1.0],
                "p_elec_w": [r.avg_p_elec_w - 100.0, r.avg_p_elec_w, r.avg_p_elec_w + 100.0],
                "p_mech_w": [r.avg_p_elec_w - 150.0, r.avg_p_elec_w - 50.0, r.avg_p_elec_w],
                "altitude_m": [30.0, 60.0, 45.0],
            }
        )
        return CycleResult(
            *vars(r).values(), period_s=4.0 + w, avg_p_mech_w=-100.0 * w, trajectory=traj
        )


def test_run_optimize_writes_every_file(tmp_path):
    import hashlib
    import json

    import pandas as pd

    from optimize.command import SweepRequest, run_optimize
    from optimize.paper_model import PAPER_MODEL_PATH, paper_model
    from optimize.resolve import resolve
    from optimize.sweep_folder import field_units, read_summary

    out = tmp_path / "optimize_out"
    request = SweepRequest(
        grid=WindGrid((4.0, 5.5, 7.0), ("elec-lim", "mech-lim")),
        setup=resolve(drive_model=paper_model(), model_path=PAPER_MODEL_PATH),
        model_note="paper model",
        workers=2,
        out=out,
    )
    done = run_optimize(request, ["bench", "optimize"], show_progress=False, backend=CycleBackend())
    summary = read_summary(out / "summary.parquet")
    assert len(summary) == 6 and summary["success"].all()
    # energy per cycle = average power x period, from the stand-in's exact values
    row = summary.set_index("scenario").loc["mech-lim-7.0"]
    assert row["e_mech_j"] == pytest.approx(-700.0 * 11.0, rel=1e-12)
    assert row["peak_speed_rpm"] == 700.0 and row["peak_torque_nm"] == 70.0
    # the paper model's domain is the rated box: every stand-in cycle point lies inside
    assert (summary["outside_domain_time_frac"] == 0.0).all()
    traj = pd.read_parquet(out / "trajectories.parquet")
    assert len(traj) == 18 and field_units(out / "trajectories.parquet")["l_m"] == "m"
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["wind_speeds_m_s"] == [4.0, 5.5, 7.0] and manifest["converged"] == 6
    assert (
        manifest["drive_model"]["file_sha256"]
        == hashlib.sha256(PAPER_MODEL_PATH.read_bytes()).hexdigest()
    )
    assert manifest["provenance"]["command_line"] == ["bench", "optimize"]
    assert manifest["options"]["discretization"]["n_intervals"] == 40
    assert manifest["provenance"]["versions"]["casadi"]
    # one task per step of the start graph, then one per kind (its re-solves, cut-in)
    assert [len(c["scenarios"]) for c in manifest["chains"]] == [1] * 6 + [3, 3]
    # each worker's setup: its tasks' NLP build times, all 8 tasks on the 2 workers
    assert sum(w["tasks"] for w in manifest["workers"]) == 8 and len(manifest["workers"]) <= 2
    assert sum(w["build_time_s"] for w in manifest["workers"]) == pytest.approx(
        sum(c["build_time_s"] for c in manifest["chains"]))
    assert summary.set_index("scenario")["depth"].to_dict() == {
        "elec-lim-5.5": 0, "mech-lim-5.5": 1, "elec-lim-4.0": 1, "elec-lim-7.0": 1,
        "mech-lim-4.0": 2, "mech-lim-7.0": 2}
    # the cut-in search recovered the stand-in's crossings (4.8 and 5.5 m/s) and the
    # claims table says so
    cut = {c["kind"]: c["cut_in_m_s"] for c in manifest["cut_in"]}
    assert cut["elec-lim"] == pytest.approx(4.8, abs=0.01)
    assert cut["mech-lim"] == pytest.approx(5.5, abs=0.01)
    claims = pd.read_csv(out / "claims.csv").set_index("claim_id")
    assert claims.loc["cut-in-elec-lim", "verdict"] == "agrees"
    assert claims.loc["cut-in-order", "verdict"] == "agrees"
    assert done.claims is not None and set(done.files) == {
        "summary",
        "trajectories",
        "claims",
        "manifest",
    }
    # without claims the old comparison is removed, not left beside new results
    run_optimize(
        dataclasses.replace(request, claims=False, grid=WindGrid((7.0,), request.grid.kinds)),
        show_progress=False,
        backend=CycleBackend(),
    )
    assert not (out / "claims.csv").exists()
    assert len(read_summary(out / "summary.parquet")) == 2


@dataclass(frozen=True)
class CrashingCycleBackend(CycleBackend):
    """CycleBackend whose solver raises at one wind speed, warm or cold."""

    crash_at: float = 5.5

    def _newton(self, kind: str, w: float, x: float) -> CycleResult:
        if w == self.crash_at:
            raise RuntimeError("solver crashed")
        return super()._newton(kind, w, x)


def test_a_solver_crash_in_an_optimize_sweep_is_reported_as_sizing_and_refine_report_it(tmp_path):
    import json

    from optimize.command import SweepRequest, run_optimize
    from optimize.paper_model import PAPER_MODEL_PATH, paper_model
    from optimize.resolve import resolve
    from optimize.service import failure_status

    out = tmp_path / "optimize_out"
    request = SweepRequest(grid=WindGrid((4.0, 5.5, 7.0), ("elec-lim",)),
                           setup=resolve(drive_model=paper_model(),
                                         model_path=PAPER_MODEL_PATH),
                           model_note="paper model", workers=1, out=out, claims=False)
    done = run_optimize(request, ["bench", "optimize"], show_progress=False,
                        backend=CrashingCycleBackend(crash_at=5.5))
    rows = done.summary.set_index("scenario")
    # the status text test_energy_sizing and test_energy_refine assert for their crashes
    status = "exception: RuntimeError: solver crashed"
    assert failure_status("exception", RuntimeError("solver crashed")) == status
    assert rows.loc["elec-lim-5.5", "status"] == status
    assert not rows.loc["elec-lim-5.5", "success"]
    assert np.isnan(rows.loc["elec-lim-5.5", "avg_p_elec_w"])  # never a figure of a crash
    # the sweep goes on: the other speeds converge from cold starts, the crash is listed
    assert rows.loc[["elec-lim-4.0", "elec-lim-7.0"], "success"].all()
    assert json.loads((out / "manifest.json").read_text())["failed"] == ["elec-lim-5.5"]


class DeadWorkerBackend(NewtonBackend):
    """A backend whose worker dies before any solve (the NLP cannot be built)."""

    def build(self, problem: Problem) -> str:
        raise RuntimeError("worker died")


def test_a_dead_worker_fails_its_chain_the_same_way_in_a_sweep_and_in_solve_tasks():
    from optimize.service import SolveTask, solve_tasks

    status = "worker error: RuntimeError: worker died"
    tasks = SweepTasks(PROBLEM, plan_graph(WINDS, ("elec-lim", "mech-lim")),
                       cut_in_kinds=("elec-lim",), backend=DeadWorkerBackend())
    with ThreadPoolExecutor(2) as ex:
        handle = ExecutorHandle(ex, QueueChannel(), "threads", 2)
        result = run_sweep(tasks, handle, show_progress=False)
        records = solve_tasks([SolveTask(PROBLEM, Scenario.of_kind("elec-lim", w)) for w in WINDS],
                              handle=handle, backend=DeadWorkerBackend())
    # nothing dropped: every planned scenario reports its task's death, and the cut-in
    # search (which needs no NLP with nothing converged) says why it found nothing
    assert len(result.outcomes) == 10 and {o.status for o in result.outcomes} == {status}
    assert [c.status for c in result.cut_ins] == ["too few converged grid speeds"]
    assert [r["wind_speed_m_s"] for r in records] == list(WINDS)
    assert {r["status"] for r in records} == {status} and not any(r["success"] for r in records)


def test_a_sweep_in_which_nothing_converged_writes_every_column_of_its_parts(tmp_path):
    """No row, and the columns of the OCP's parts (time, variables, outputs) with units:
    the same columns a converged sweep writes, from the parts, not from a solution."""
    from optimize.command import SweepRequest, run_optimize
    from optimize.model.kite_model import kite_dae
    from optimize.paper_model import PAPER_MODEL_PATH, paper_model
    from optimize.problem.ocp import build_ocp
    from optimize.problem.part import trajectory_columns
    from optimize.resolve import resolve
    from optimize.sweep_folder import field_units

    out = tmp_path / "optimize_out"
    setup = resolve(drive_model=paper_model(), model_path=PAPER_MODEL_PATH)
    request = SweepRequest(grid=WindGrid((5.5, 7.0), ("elec-lim",)), setup=setup,
                           model_note="paper model", workers=1, out=out, claims=False)
    done = run_optimize(request, ["bench", "optimize"], show_progress=False,
                        backend=DeadWorkerBackend())
    assert not done.summary["success"].any()
    units = field_units(out / "trajectories.parquet")
    ocp = build_ocp(kite_dae(*setup.system.model_params()), paper_model(), setup.options,
                    system=setup.system)
    columns = trajectory_columns(ocp.formulation.parts)
    assert list(units) == ["scenario", "kind", "wind_speed_m_s", *columns]
    assert {c: units[c] for c in columns} == columns
    assert units["speed_rpm"] == "rpm" and units["nu_n_per_m"] == "N/m"


@dataclass(frozen=True)
class BoundedBackend(NewtonBackend):
    """The exact stand-in whose result check rejects every optimum generating more than
    ``bound_w`` (as the Loyd-type bound rejects an impossible one)."""

    bound_w: float = 300.0

    def check(self, ocp, result, name):
        from optimize.analysis.result_check import ResultCheck

        generated = -result.avg_p_elec_w
        reasons = (f"{generated:.0f} W generated, above {self.bound_w:.0f} W",
                   ) if generated > self.bound_w else ()
        return ResultCheck(name, "stand-in", generated, self.bound_w, 0.0, 0.0, 0.0, 0.0,
                           reasons)


def test_an_optimum_failing_its_result_check_is_failed_in_every_service_path():
    """The check runs where the service solves, so ``bench size`` and ``bench aep --refine``
    (``solve_tasks``, ``run_chains``) fail such an optimum as ``bench optimize`` does: not
    converged, the solver's status kept, the reason in ``result_check``, never a warm start."""
    from optimize.service import SolveTask, solve_tasks

    backend = BoundedBackend()
    truth = {w: SCALE_W * (exact_root(CUT_IN_M_S["elec-lim"]) - exact_root(w)) for w in WINDS}
    records = solve_tasks([SolveTask(PROBLEM, Scenario.of_kind("elec-lim", w)) for w in WINDS],
                          workers=1, backend=backend)
    for r in records:
        impossible = -truth[r["wind_speed_m_s"]] > backend.bound_w
        assert r["success"] is not impossible and r["status"] == "Solve_Succeeded"
        assert r["result_check"].startswith("failed: ") is impossible, r
        if not impossible:
            assert r["avg_p_elec_w"] == pytest.approx(truth[r["wind_speed_m_s"]], abs=1e-6)
    assert sum(not r["success"] for r in records) == 2  # 8.5 and 10 m/s: above 300 W
    solves = Solves(PROBLEM, backend=backend)
    scenario = Scenario.of_kind("elec-lim", 10.0)
    solves.solve(scenario)
    outcome = solves.outcomes[scenario]
    assert not outcome.success and outcome.check.startswith("failed: ")
    assert solves.converged("elec-lim") == []  # a failed optimum starts nothing


@dataclass(frozen=True)
class ArtifactBackend(BoundedBackend):
    """``bad`` converges to a non-physical optimum (1 MW generated: the result check fails
    it) from a cold start and from every start of its own kind; from the other objective's
    optimum it finds the true one. The warm start carries the kind it came from."""

    bound_w: float = 1e5
    bad: str = "mech-free-10.0"

    def _from(self, kind: str, w: float, x: float, source_kind: str | None) -> Result:
        r = self._newton(kind, w, x)
        artifact = scenario_name(kind, w) == self.bad and source_kind in (None, kind)
        return dataclasses.replace(r, warm=(r.warm, kind),
                                   avg_p_elec_w=r.avg_p_elec_w - 1e6 * artifact)

    def solve(self, ocp: str, scenario: Scenario, warm: tuple) -> Result:
        kind, w = scenario.kind, scenario.wind_speed_m_s
        return self._from(kind, w, warm[0], warm[1])

    def cold_start(self, ocp: str, scenario: Scenario) -> Result:
        kind, w = scenario.kind, scenario.wind_speed_m_s
        return self._from(kind, w, 0.0, None)


def test_a_failed_result_check_is_retried_from_the_other_starts_before_it_fails():
    result = _sweep(("elec-free", "mech-free"), backend=ArtifactBackend())
    by_name = {o.name: o for o in result.outcomes}
    bad = by_name["mech-free-10.0"]
    # its planned starts and the cold start converge to the artifact, the check fails them;
    # then the other converged speeds of its kind (nearest first), then elec-free-10.0
    assert [a.source for a in bad.attempts] == [
        "mech-free-8.5", "mech-free-7.0", None, "mech-free-5.5", "mech-free-4.0",
        "elec-free-10.0"]
    assert [a.verdict.split(":")[0] for a in bad.attempts] == ["failed"] * 5 + ["passed"]
    assert bad.success and bad.warm_source == "elec-free-10.0"  # the summary says which
    truth = SCALE_W * (exact_root(CUT_IN_M_S["mech-free"]) - exact_root(10.0))
    assert bad.result.avg_p_elec_w == pytest.approx(truth, rel=1e-9)
    assert bad.depth == by_name["elec-free-10.0"].depth + 1
    assert all(o.success for o in result.outcomes) and len(result.outcomes) == 10
    # with no other objective to start from it fails, every try listed
    alone = {o.name: o for o in _sweep(("mech-free",), backend=ArtifactBackend()).outcomes}
    assert not alone["mech-free-10.0"].success and len(alone["mech-free-10.0"].attempts) == 5
    assert alone["mech-free-10.0"].check.startswith("failed: 999408 W generated, above 100000")
    assert alone["mech-free-10.0"].warm_source == "mech-free-4.0"
    assert alone["mech-free-10.0"].depth == 3  # from mech-free-4.0, 2 deep



@dataclass(frozen=True)
class CoarseMeshBackend(ArtifactBackend):
    """``bad`` converges to the artifact on every mesh below ``fine_enough`` intervals, as a
    cycle its mesh is too coarse for fails the re-integration check; its own result
    solved again on a mesh of ``fine_enough`` or more (``remesh``) is the true optimum.
    The built OCP is the problem itself, so ``remesh`` sees both meshes."""

    fine_enough: int = 40

    def build(self, problem: Problem) -> Problem:
        return problem

    def remesh(self, coarse: Problem, fine: Problem, scenario: Scenario, result: Result
               ) -> Result:
        kind, w = scenario.kind, scenario.wind_speed_m_s
        assert fine.n_intervals == 2 * coarse.n_intervals
        r = self._newton(kind, w, result.warm[0])
        artifact = fine.n_intervals < self.fine_enough
        return dataclasses.replace(r, warm=(r.warm, kind),
                                   avg_p_elec_w=r.avg_p_elec_w - 1e6 * artifact)


def test_an_optimum_the_mesh_is_too_coarse_for_is_solved_on_a_finer_one_before_it_fails():
    from types import SimpleNamespace

    import pandas as pd

    from optimize.problem.options import Discretization, OcpOptions
    from optimize.sweep_folder import remesh_lines, unchecked_lines

    options = OcpOptions(Discretization(n_intervals=10))
    problem = Problem(None, SimpleNamespace(sha256="stand-in"), options, "stand-in 10")
    result = _sweep(("mech-free",), backend=CoarseMeshBackend(), problem=problem)
    bad = {o.name: o for o in result.outcomes}["mech-free-10.0"]
    # every start of its kind gives the artifact (as in the test above); then its own
    # optimum on 20 intervals (still the artifact) and on 40 (the true optimum)
    assert [a.source for a in bad.attempts][-2:] == ["mech-free-10.0 on 20 intervals",
                                                     "mech-free-10.0 on 40 intervals"]
    assert [a.verdict.split(":")[0] for a in bad.attempts] == ["failed"] * 6 + ["passed"]
    assert bad.success and bad.warm_source == "mech-free-10.0 on 40 intervals"
    truth = SCALE_W * (exact_root(CUT_IN_M_S["mech-free"]) - exact_root(10.0))
    assert bad.result.avg_p_elec_w == pytest.approx(truth, rel=1e-9)
    assert all(o.success for o in result.outcomes)
    frame = pd.DataFrame([{"scenario": o.name, "kind": o.kind, "success": o.success,
                           "n_intervals": 40,
                           "warm_source": o.warm_source} for o in result.outcomes])
    assert remesh_lines(frame) == ["mech-free-10.0: on 40 intervals"]  # the log's, the report's
    assert unchecked_lines(frame) == []  # five converged speeds: the local optima are checked
    # one refinement short of the mesh it needs: failed, every try listed
    short = _sweep(("mech-free",), backend=CoarseMeshBackend(fine_enough=80), problem=problem)
    bad = {o.name: o for o in short.outcomes}["mech-free-10.0"]
    assert not bad.success and len(bad.attempts) == 7 and bad.check.startswith("failed: ")


def test_a_finer_mesh_is_not_solved_once_the_scenario_s_budget_is_spent():
    from types import SimpleNamespace

    from optimize.problem.options import Discretization, OcpOptions, SolverOptions
    from optimize.service.outcome import Attempt, ScenarioOutcome
    from optimize.service.retry import retry_on_finer_mesh
    from optimize.service.solves import Solves, spent_status

    options = OcpOptions(Discretization(n_intervals=10),
                         solver=SolverOptions(call_time_limit_s=0.05))
    problem = Problem(None, SimpleNamespace(sha256="stand-in"), options, "stand-in 10")
    backend = CoarseMeshBackend()
    bad = Scenario.of_kind("mech-free", 10.0)
    artifact = backend.cold_start(problem, bad)  # converged, its check failed
    outcome = ScenarioOutcome(bad, 0, (Attempt(None, "Solve_Succeeded", False, 3, 0.1),),
                              artifact)
    solves = Solves(problem, backend=backend)
    solves.spent_s[bad] = problem.scenario_budget_s  # 8 call limits: 0.4 s, all spent
    done = retry_on_finer_mesh(solves, outcome)
    # each finer mesh asked for is not run, says why, and the result stays the coarse one
    tried = done.attempts[1:]
    assert [a.source for a in tried] == ["mech-free-10.0 on 20 intervals",
                                         "mech-free-10.0 on 40 intervals"]
    assert all(a.status == spent_status(0.4) and not a.success and a.wall_time_s == 0.0
               for a in tried)
    assert done.result is artifact and not done.success

# ----------------------------------------------------------------- local optima
@dataclass(frozen=True)
class BranchResult(Result):
    period_s: float = 5.0
    avg_p_mech_w: float = 0.0


@dataclass(frozen=True)
class BranchBackend:
    """Two optima per wind: branch "good" (P = -100 w^2, period 5 s) everywhere and a local
    branch "local" 300 W worse (period 8 s) that exists only between 6 and 8 m/s. A warm
    start stays on its source's branch where it exists; the cold start lands on "local"."""

    def build(self, problem: Problem) -> str:
        return problem.key

    @staticmethod
    def _on(branch: str, w: float) -> BranchResult:
        branch = branch if branch == "good" or 6.0 <= w <= 8.0 else "good"
        local = branch == "local"
        return BranchResult("Solve_Succeeded", True, 3, 1e-3, -100.0 * w**2 + 300.0 * local,
                            branch, period_s=8.0 if local else 5.0)

    def solve(self, ocp: str, scenario: Scenario, warm: str) -> BranchResult:
        w = scenario.wind_speed_m_s
        return self._on(warm, w)

    def cold_start(self, ocp: str, scenario: Scenario) -> BranchResult:
        w = scenario.wind_speed_m_s
        return self._on("local", w)

    def check(self, ocp, result, name):
        return None  # an exact stand-in solver: nothing to check


def test_a_local_optimum_off_the_curve_is_resolved_from_its_neighbour():
    from optimize.sweep.outputs import resolve_fields, resolve_lines

    done = run_chain(ChainTask(PROBLEM, chain_steps(("elec-free",), WINDS),
                               backend=BranchBackend(), resolve=True))
    by_name = {o.name: o for o in done.outcomes}
    mid = by_name["elec-free-7.0"]  # the cold start: on the local branch, 300 W worse
    assert mid.result.avg_p_elec_w == pytest.approx(-4900.0)  # the better optimum kept
    # from the neighbour nearer its own curve (8.5 m/s: 5.5 sits nearer the local branch)
    assert mid.result.warm == "good" and mid.attempts[-1].source == "elec-free-8.5"
    assert [r.kept for r in mid.resolves] == [True]
    assert mid.resolves[0].before_w == pytest.approx(-4600.0)
    row = resolve_fields(mid)  # the summary's columns
    assert row["resolved_from"] == "elec-free-8.5"
    assert row["resolve_gain_w"] == pytest.approx(300.0)
    assert "better optimum, kept" in resolve_lines([mid])[0]  # the manifest's local_optima
    import pandas as pd

    from optimize.command import format_summary
    from optimize.sweep_folder import resolve_lines_of

    frame = pd.DataFrame([{"scenario": mid.name, **row}])
    line = "elec-free-7.0: re-solved from elec-free-8.5: better by 300.0 W, kept"
    assert resolve_lines_of(frame) == [line]
    assert line in format_summary(frame.assign(
        status="Solve_Succeeded", iterations=3, total_wall_time_s=0.0, avg_p_elec_w=-4900.0,
        avg_p_mech_w=0.0, period_s=5.0, e_elec_j=0.0, peak_speed_rpm=0.0, peak_torque_nm=0.0,
        p_elec_max_w=0.0, slack_fraction=0.0, success=True, active_bounds="",
        bound_limited=False, outside_domain_time_frac=float("nan")))
    # 7.0's better optimum is carried on to both neighbours (the good branch they are on
    # already: the same optimum, not kept); nothing else is re-solved
    for name in ("elec-free-5.5", "elec-free-8.5"):
        assert [(r.carried, r.kept) for r in by_name[name].resolves] == [(True, False)]
        assert by_name[name].result.avg_p_elec_w == pytest.approx(-100.0 * float(name[-3:])**2)
    assert all(o.result.warm == "good" for o in done.outcomes)


def test_a_seed_on_a_local_optimum_is_caught_and_resolved_in_the_graph():
    # the seed (elec-free-7.0, a cold start) lands on the local branch; its neighbours,
    # started from it, find the good branch (the local one does not exist there); the
    # per-kind task after the graph re-solves the seed from a neighbour and keeps it
    result = _sweep(("elec-free",), backend=BranchBackend())
    by_name = {o.name: o for o in result.outcomes}
    mid = by_name["elec-free-7.0"]
    assert [r.kept for r in mid.resolves] == [True] and mid.result.warm == "good"
    assert mid.result.avg_p_elec_w == pytest.approx(-4900.0)
    assert mid.attempts[-1].source in ("elec-free-5.5", "elec-free-8.5")
    assert mid.depth == by_name[mid.attempts[-1].source].depth + 1 == 2
    assert all(o.result.warm == "good" for o in result.outcomes)


@dataclass(frozen=True)
class LadderBackend(BranchBackend):
    """Branch "good" everywhere and a branch "poor", 1500 W worse with a period of 8 s,
    that exists up to 8.5 m/s: the cold start (7 m/s) and the chain from it land on
    "poor" up to 8.5 m/s, and only the last speed, 10 m/s, finds "good"."""

    @staticmethod
    def _on(branch: str, w: float) -> BranchResult:
        poor = branch != "good" and w <= 8.5
        return BranchResult("Solve_Succeeded", True, 3, 1e-3, -100.0 * w**2 + 1500.0 * poor,
                            "poor" if poor else "good", period_s=8.0 if poor else 5.0)


def test_a_better_branch_found_at_one_end_is_carried_along_the_kind():
    done = run_chain(ChainTask(PROBLEM, chain_steps(("elec-free",), WINDS),
                               backend=LadderBackend(), resolve=True))
    by_name = {o.name: o for o in done.outcomes}
    # every speed ends on the good branch, at its exact power
    for name, o in by_name.items():
        assert o.result.warm == "good", name
        assert o.result.avg_p_elec_w == pytest.approx(-100.0 * o.wind_speed_m_s**2)
    # 8.5 m/s, off the curve, finds it from 10 m/s; the better optimum is carried on down
    # the kind, each speed from the one above, each kept
    hop = by_name["elec-free-8.5"].resolves
    assert [(r.attempt.source, r.carried, r.kept) for r in hop][0] == (
        "elec-free-10.0", False, True)
    for w, above in ((7.0, 8.5), (5.5, 7.0), (4.0, 5.5)):
        rs = by_name[f"elec-free-{w}"].resolves
        assert [(r.attempt.source, r.carried, r.kept) for r in rs][0] == (
            f"elec-free-{above}", True, True)
        assert rs[0].before_w - rs[0].objective_w == pytest.approx(1500.0)
    # and back up: 10 m/s from 8.5 m/s's new optimum, the one it had (not kept); then each
    # speed the better branch was carried from is checked once from the speed below it
    # (the same branch: not kept); nothing else is solved again
    top = by_name["elec-free-10.0"].resolves
    assert [(r.attempt.source, r.carried, r.kept) for r in top] == [
        ("elec-free-8.5", True, False)]
    for w, below in ((8.5, 7.0), (7.0, 5.5), (5.5, 4.0)):
        rs = by_name[f"elec-free-{w}"].resolves
        assert [(r.attempt.source, r.back, r.kept) for r in rs][1:] == [
            (f"elec-free-{below}", True, False)]
    assert len(by_name["elec-free-4.0"].resolves) == 1


@dataclass(frozen=True)
class HiddenBranchBackend(LadderBackend):
    """The ladder, and a branch "best", 100 W better than "good" (too little to put a speed
    off the curve), that exists up to 8.5 m/s but that only a start on "good" at 7 m/s or
    below finds: the good branch carried down from 10 m/s finds it at 7 m/s, below the
    speed (8.5) that carried it there."""

    @staticmethod
    def _on(branch: str, w: float) -> BranchResult:
        if branch == "best" and w <= 8.5 or branch == "good" and w <= 7.0:
            return BranchResult("Solve_Succeeded", True, 3, 1e-3, -100.0 * w**2 - 100.0,
                                "best", period_s=5.0)
        return LadderBackend._on(branch, w)


def test_a_branch_found_below_the_speed_that_carried_it_is_brought_back():
    done = run_chain(ChainTask(PROBLEM, chain_steps(("elec-free",), WINDS),
                               backend=HiddenBranchBackend(), resolve=True))
    by_name = {o.name: o for o in done.outcomes}
    # 7 m/s, re-solved from 8.5 m/s's good optimum, finds "best"; 8.5 m/s (whose re-solve
    # from 10 m/s carried the good branch down) is solved again from it and keeps it too
    mid = by_name["elec-free-8.5"]
    assert [(r.attempt.source, r.carried, r.back, r.kept) for r in mid.resolves] == [
        ("elec-free-10.0", False, False, True), ("elec-free-7.0", False, True, True)]
    for w in WINDS[:-1]:
        o = by_name[scenario_name("elec-free", w)]
        assert o.result.warm == "best", w
        assert o.result.avg_p_elec_w == pytest.approx(-100.0 * w**2 - 100.0)
    # 10 m/s, where "best" does not exist, is tried from it and stays on "good"
    top = by_name["elec-free-10.0"]
    assert top.result.warm == "good" and not any(r.kept for r in top.resolves)
    assert [r.attempt.source for r in top.resolves][-1] == "elec-free-8.5"


def test_the_limited_kind_starts_on_the_branch_its_lead_settled():
    # the lead (elec-free) lands on the poor branch up to 8.5 m/s and its re-solves carry
    # the good one down from 10 m/s; only then does elec-lim start, each speed from the
    # lead's final optimum there: on the good branch at once, with nothing to re-solve
    result = _sweep(("elec-lim", "elec-free"), backend=LadderBackend())
    assert [o.kind for o in result.outcomes] == ["elec-lim"] * 5 + ["elec-free"] * 5
    by_name = {o.name: o for o in result.outcomes}
    for w in WINDS:
        lead = by_name[scenario_name("elec-free", w)]
        limited = by_name[scenario_name("elec-lim", w)]
        assert lead.result.warm == limited.result.warm == "good"
        assert limited.attempts == (limited.attempts[0],)
        assert limited.attempts[0].source == lead.name and limited.resolves == ()
    # the lead's four kept, one not, and three checks back from the speed below (not kept)
    assert sum(len(o.resolves) for o in result.outcomes) == 8


def test_a_smooth_power_curve_is_not_resolved():
    from optimize.service.local_optima import off_curve

    winds = [4.0 + i for i in range(10)]
    power = [-3.0 * w**3 + 40 for w in winds]  # cubic in the wind, crossing zero near 2.4 m/s
    period = [12.0 - 0.5 * w for w in winds]
    assert off_curve(winds, power, period) == []
    bumped = list(power)
    bumped[8] *= 0.95  # 5 % less generated at 12 m/s: the AP2 case (-5673 W for -5974 W)
    assert 8 in off_curve(winds, bumped, period)
    better = list(power)
    better[8] *= 1.05  # 5 % more generated: no local optimum there (its neighbours may be)
    assert 8 not in off_curve(winds, better, period)
    # AP2's elec-lim over 6:12:3: a concave curve whose middle the chord underestimates
    assert 1 not in off_curve([6.0, 9.0, 12.0], [-705.0, -2672.0, -3815.0], [20.0, 28.9, 38.1])
    jumped = list(period)
    jumped[7] *= 1.3  # a period jump alone
    assert 7 in off_curve(winds, power, jumped)


def test_every_solver_run_says_what_it_is_doing():
    """Each solver run, the local-optimum re-solves included, is announced before it runs
    and reported after, so the progress bar names the phase it is in."""
    from optimize.service.executors import QueueChannel
    from optimize.service.solves import attempt_line

    channel = QueueChannel()
    run_chain(ChainTask(PROBLEM, chain_steps(("elec-free",), WINDS), backend=BranchBackend(),
                        resolve=True), progress=channel)
    runs = [e for e in channel.drain() if "attempt" in e]
    assert [e["attempt"] for e in runs] == ["start", "done"] * (len(runs) // 2)
    assert {e["role"] for e in runs} == {"grid", "local optimum"}
    lines = [attempt_line(e) for e in runs if e["role"] == "local optimum"]
    # the re-solve that finds the better optimum of 7 m/s (see the test above)
    assert "local optimum: elec-free-7.0 from elec-free-8.5 ..." in lines
    assert "local optimum: elec-free-7.0 from elec-free-8.5 Solve_Succeeded" in lines
    # and carries it on (to 5.5 m/s) and back (8.5 m/s)
    assert "local optimum: elec-free-5.5 from elec-free-7.0 Solve_Succeeded" in lines
    assert "local optimum: elec-free-8.5 from elec-free-7.0 Solve_Succeeded" in lines


def test_workers_default_to_the_affinity_mask_and_the_header_says_why(monkeypatch):
    # a process pinned to 3 of the machine's cores (taskset, a container's share) gets 3
    # workers, not the machine's count; --workers overrides it
    from optimize import sweep_options
    from optimize.sweep_options import CORES_REASON, Execution

    monkeypatch.setattr(sweep_options.os, "sched_getaffinity", lambda pid: {0, 2, 5},
                        raising=False)
    monkeypatch.setattr(sweep_options.os, "cpu_count", lambda: 64)
    default = Execution()
    assert default.workers == 3 and default.workers_reason == CORES_REASON
    assert default.line() == "3 workers: the cores this process may use"
    assert Execution(1).line() == "1 worker: --workers"
    monkeypatch.delattr(sweep_options.os, "sched_getaffinity")
    assert Execution().workers == 64
