"""A sweep ends within the time it states before it starts, converged or failed.

Each scenario's solver runs, all together, start within
:data:`~optimize.problem.deadline.SCENARIO_CALLS` call limits (:class:`Solves`), and a
solver call that never returns ends its worker of the local pool at its hard stop
(:func:`~optimize.problem.deadline.hard_stop`), which stops the run with what finished
(:class:`~optimize.service.executors.WorkerLost`). Stand-in solvers that are slow, fail
or hang, no real solve: the exact Newton stand-in of tests/test_sweep.py where they
converge.
"""

from __future__ import annotations

import collections
import itertools
import math
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import pytest
from service_fixtures import Result
from test_sweep import SCALE_W, WINDS, CycleBackend, NewtonBackend, exact_root

from optimize.problem.deadline import SCENARIO_CALLS, deadline, hard_stop, passed
from optimize.problem.options import OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.service import Problem, SweepTasks, run_sweep
from optimize.service.executors import ExecutorHandle, QueueChannel, open_executor
from optimize.service.plan import plan_graph
from optimize.service.run import POOL_BROKE
from optimize.service.solves import spent_status

#: the stand-ins' call limit [s] (--call-time-limit)
LIMIT_S = 0.05
BOUNDED = Problem(model=None, drive_model=None, key="bounded",
                  options=OcpOptions(solver=SolverOptions(call_time_limit_s=LIMIT_S)))
CUT_IN_M_S = {"elec-lim": 4.8, "mech-lim": 5.5, "elec-free": 4.6}


@dataclass(frozen=True)
class SlowBackend(NewtonBackend):
    """The Newton stand-in, but every solve of a ``slow`` kind runs ``calls`` call
    limits, each call to its deadline (as the condensed NLP's calls end there), and
    fails: only the scenario's budget stops it sooner."""

    slow: tuple[str, ...] = ("mech-lim",)
    calls: int = 20

    def _run(self, scenario: Scenario, x: float, kind_solve) -> Result:
        if scenario.kind not in self.slow:
            return kind_solve()
        t0 = time.monotonic()
        with deadline(self.calls * LIMIT_S):
            while not passed():
                time.sleep(0.002)
        return Result("Wall_Time_Limit", False, 0, time.monotonic() - t0, math.nan, x)

    def solve(self, ocp, scenario, warm):
        return self._run(scenario, warm, lambda: super(SlowBackend, self).solve(
            ocp, scenario, warm))

    def cold_start(self, ocp, scenario):
        return self._run(scenario, 0.0, lambda: super(SlowBackend, self).cold_start(
            ocp, scenario))


def _thread_sweep(kinds, backend):
    tasks = SweepTasks(BOUNDED, plan_graph(WINDS, kinds), backend=backend, selected=kinds)
    with ThreadPoolExecutor(2) as ex:
        return run_sweep(tasks, ExecutorHandle(ex, QueueChannel(), "threads", 2),
                         show_progress=False)


def test_each_scenario_s_solver_runs_stop_at_its_budget():
    kinds = ("elec-lim", "mech-lim")
    t0 = time.monotonic()
    result = _thread_sweep(kinds, SlowBackend())
    wall_s = time.monotonic() - t0
    budget_s = SCENARIO_CALLS * LIMIT_S
    assert BOUNDED.scenario_budget_s == pytest.approx(budget_s)
    slow = [o for o in result.outcomes if o.kind == "mech-lim"]
    assert len(slow) == 5 and not any(o.success for o in slow)
    for o in slow:
        # its runs, all its tasks together: the budget and the stand-in's sleep step
        assert o.total_wall_time_s <= budget_s + 0.05, o
        # the first run spent it all (20 call limits asked for); the cold start after it
        # did not run, and says why
        assert o.attempts[0].wall_time_s == pytest.approx(budget_s, abs=0.05)
        assert o.status == spent_status(budget_s)
        assert "8 times --call-time-limit" in o.status and o.attempts[-1].wall_time_s == 0.0
    # what converged is kept, exact (Newton's root, independently by numpy's companion matrix)
    for o in result.outcomes:
        if o.kind == "elec-lim":
            assert o.success
            want = SCALE_W * (exact_root(4.8) - exact_root(o.wind_speed_m_s))
            assert o.result.avg_p_elec_w == pytest.approx(want, rel=1e-9)
    # the sweep's bound: its slow scenarios one after another, each within (N + 1) limits;
    # without the budget each took 3 x 20 limits (3 s), 15 s on one worker, 7.5 s on two
    assert wall_s < 5 * (SCENARIO_CALLS + 1) * LIMIT_S + 1.0


def test_a_problem_without_solver_options_has_no_budget():
    assert Problem(model=None, drive_model=None, options=None, key="x").scenario_budget_s \
        == math.inf


def test_the_time_bound_is_said_before_the_sweep():
    from optimize.command import make_request
    from optimize.sweep_options import SolverChoice, WindGrid

    grid = WindGrid.parse("7,8.5", "elec-lim,mech-lim")
    solver = SolverChoice(10, 4, "fatrop", None, True, "condensed", False, None, 30.0)
    line = make_request(grid, solver, claims=False).time_bound()
    # 4 scenarios x (8 + 1) x 30 s = 1080 s; a hung call stops at 2 x 30 + 60 s
    assert "4 scenarios, each at most 270 s" in line and "18 min in all" in line
    assert "120 s after it began" in line
    # the cut-in probes of the two limited kinds: 1.5 m/s halved to 0.047 <= 0.05 in 5
    line = make_request(grid, solver).time_bound()
    assert "4 scenarios and up to 10 cut-in probes" in line and "63 min in all" in line
    inf = SolverChoice(10, 4, "ipopt", None, True, "collocation", False, None, math.inf)
    assert "none (--call-time-limit inf" in make_request(grid, inf).time_bound()


def test_a_hung_call_ends_a_pool_worker_at_its_hard_stop_and_nothing_else():
    # a loop in C that holds the interpreter, as fatrop's inertia correction did
    hang = "collections.deque(itertools.repeat(None), maxlen=0)"
    script = ("import collections, itertools, os\n"
              "from optimize.problem.deadline import hard_stop, pool_worker\n"
              "pool_worker(os.getppid())\n"
              f"with hard_stop(0.1, grace_s=0.0):\n    {hang}\n")
    t0 = time.monotonic()
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=60, check=False)
    assert run.returncode == 1 and run.stderr == ""  # the watchdog's dump goes nowhere
    assert time.monotonic() - t0 < 30
    # outside a pool worker nothing is armed: a call past its hard stop goes on
    with hard_stop(0.01, grace_s=0.0):
        time.sleep(0.1)


@dataclass(frozen=True)
class HangingBackend(CycleBackend):
    """The cycle stand-in, whose solves of one scenario never return (a loop in C under a
    hard stop of ``LIMIT_S``, as :func:`optimize.solve.nlp_solver.run` arms it)."""

    hang: str = "elec-lim-10.0"

    def _newton(self, kind, w, x):
        if Scenario.of_kind(kind, w).name == self.hang:
            with hard_stop(LIMIT_S, grace_s=0.0):
                collections.deque(itertools.repeat(None), maxlen=0)
        return super()._newton(kind, w, x)


def test_a_sweep_whose_solver_hangs_stops_with_what_finished():
    kinds = ("elec-free", "elec-lim")  # elec-free leads (stage 0), elec-lim starts from it
    tasks = SweepTasks(BOUNDED, plan_graph(WINDS, kinds), backend=HangingBackend(),
                       selected=kinds)
    t0 = time.monotonic()
    with open_executor(workers=2) as handle:
        result = run_sweep(tasks, handle, show_progress=False)
    assert time.monotonic() - t0 < 60  # without the hard stop it never ends
    assert result.stopped == "WORKER LOST" and "taken to hang" in result.lost
    assert "going on longest then: grid: elec-lim-10.0" in result.lost
    by_name = {o.name: o for o in result.outcomes}
    assert len(by_name) == 10
    # the hung scenario, and any that ran beside it, failed naming the pool's loss
    assert by_name["elec-lim-10.0"].status == f"worker error: {POOL_BROKE}"
    # stage 0 finished before: kept, exact
    for w in WINDS:
        o = by_name[Scenario.of_kind("elec-free", w).name]
        assert o.success and o.result.avg_p_elec_w == pytest.approx(
            SCALE_W * (exact_root(4.6) - exact_root(w)), rel=1e-9)
    # the rest of stage 1 converged, died with the pool or was not run: never a figure
    for w in WINDS:
        o = by_name[Scenario.of_kind("elec-lim", w).name]
        assert o.success or o.status.startswith(("worker error", "not run: worker lost"))


def test_bench_optimize_says_the_hang_and_the_solver_to_use(tmp_path, monkeypatch, capsys):
    import optimize.command
    from drivebench.cli import main

    real = optimize.command.run_optimize

    def with_stand_in(request, command_line=None, show_progress=True, backend=None):
        return real(request, command_line, show_progress, backend=HangingBackend(
            hang="mech-lim-7.0"))

    monkeypatch.setattr(optimize.command, "run_optimize", with_stand_in)
    code = main(["optimize", "--wind-grid", "5.5,7", "--scenarios", "elec-lim,mech-lim",
                 "--no-claims", "--solver", "fatrop", "--call-time-limit", "30",
                 "--out", str(tmp_path / "o"), "--no-progress"])
    out, err = capsys.readouterr()
    assert "time bound: 4 scenarios, each at most 270 s" in out
    assert "WORKER LOST: a worker process ended abruptly" in err
    assert "NOT RUN (the run stopped)" in err and "Traceback" not in out + err
    assert "FAILED (status in summary.parquet, never averaged):" in out
    assert "mech-lim-7.0" in out.split("FAILED")[1] and "Use --solver ipopt" in out
    assert code in (1, 3)  # the scenarios' exit code: a re-run hangs the same way
    assert (tmp_path / "o" / "summary.parquet").is_file()


def test_casadi_s_warning_after_a_failed_call_is_dropped_and_nothing_else(capsys):
    from optimize.solve.nlp_solver import QUIET_WARNINGS, _quiet_stderr

    with _quiet_stderr(QUIET_WARNINGS):
        # in pieces, as CasADi writes it (was: 'CasADi - ... WARNING("") [...]' left over)
        for piece in ('CasADi - 2026-12-07 20:04:19 WARNING("', "Failed to calculate "
                      "multipliers", '") [.../casadi/core/nlpsol.cpp:859]', "\n"):
            sys.stderr.write(piece)
        print("another warning", file=sys.stderr)
        sys.stderr.write("and an unfinished line")
    assert capsys.readouterr().err == "another warning\nand an unfinished line"
    print("Failed to calculate multipliers", file=sys.stderr)  # outside a call: as it is
    assert "Failed to calculate" in capsys.readouterr().err


def test_the_iterations_line_names_the_solver_that_ran():
    from optimize.cli import iterations_line

    its = {"reported": 12, "intermediate_points": 0, "intermediate_iterations": 0, "all": 30,
           "by_role": {"grid": 30}}
    assert iterations_line(its, "fatrop").startswith("fatrop iterations: 12 in the scenarios'")
    assert iterations_line(its).startswith("IPOPT iterations: 12")
    # and the report's row of the sweep's manifest
    from reports.optimization_section import run_rows

    for solver, row in (("fatrop", "fatrop iterations"), ("ipopt", "IPOPT iterations")):
        rows = dict(run_rows({"iterations": its, "options": {"solver": {"solver": solver}}},
                             None))
        assert rows[row].startswith("12 in the scenarios' final solves")


@dataclass(frozen=True)
class FailingBackend(NewtonBackend):
    """The Newton stand-in, but every solve fails except those of the scenarios ``ok``."""

    ok: tuple[str, ...] = ()

    def _newton(self, kind, w, x):
        result = super()._newton(kind, w, x)
        if Scenario.of_kind(kind, w).name in self.ok:
            return result
        return Result("fatrop return flag 2: failed", False, 5, 1e-3, math.nan, x)


def _give_up_sweep(backend, give_up_after=3):
    kinds = ("elec-lim",)
    tasks = SweepTasks(BOUNDED, plan_graph(WINDS, kinds), backend=backend, selected=kinds,
                       give_up_after=give_up_after)
    with ThreadPoolExecutor(2) as ex:
        return run_sweep(tasks, ExecutorHandle(ex, QueueChannel(), "threads", 2),
                         show_progress=False)


def test_a_sweep_gives_its_solver_up_after_failures_with_none_converged():
    result = _give_up_sweep(FailingBackend())
    assert result.stopped == "STOPPED" and "3 scenarios failed and none converged" in result.lost
    status = {o.name: o.status for o in result.outcomes}
    # the seed (7 m/s) and the two speeds it starts (5.5, 8.5) failed; the outer two not
    # run, or one of them when its source failed and handed it on before the third failure
    assert status["elec-lim-7.0"] == status["elec-lim-5.5"] == status["elec-lim-8.5"] \
        == "fatrop return flag 2: failed"
    not_run = {n for n, s in status.items() if s.startswith("not run")}
    assert not_run and not_run <= {"elec-lim-4.0", "elec-lim-10.0"}
    assert {status[n] for n in not_run} == {
        "not run: gave up: 3 scenarios failed and none converged"}
    # never without the rule, nor once one converged: every scenario is tried
    for kept in (_give_up_sweep(FailingBackend(), give_up_after=0),
                 _give_up_sweep(FailingBackend(ok=("elec-lim-7.0",)))):
        assert kept.stopped == "" and kept.lost is None
        assert not any(o.status.startswith("not run") for o in kept.outcomes)


def test_bench_optimize_with_fatrop_stops_and_names_ipopt(tmp_path, monkeypatch, capsys):
    import optimize.command
    from drivebench.cli import main

    real = optimize.command.run_optimize
    monkeypatch.setattr(optimize.command, "run_optimize", lambda request, line, show_progress:
                        real(request, line, show_progress, backend=CycleBackend(max_iter=1)))
    code = main(["optimize", "--wind-grid", "4:10:1.5", "--scenarios", "elec-lim",
                 "--no-claims", "--solver", "fatrop", "--workers", "1",
                 "--out", str(tmp_path / "o"), "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 1 and "Traceback" not in out + err
    assert "STOPPED: 3 scenarios failed and none converged" in err
    # 4 and 10 m/s, or one of them when it was handed to the worker before the third failure
    not_run = err.split("NOT RUN (the run stopped): ")[1].splitlines()[0].split(", ")
    assert not_run and set(not_run) <= {"elec-lim-4.0", "elec-lim-10.0"}
    assert "Use --solver ipopt" in out and "fatrop iterations:" in out
    import pandas as pd

    summary = pd.read_parquet(tmp_path / "o" / "summary.parquet")
    assert len(summary) == 5 and not summary["success"].any()


def test_every_solver_call_runs_under_its_hard_stop(monkeypatch):
    # the wiring: nlp_solver.run arms the hard stop of its own call limit around the call
    import contextlib

    from test_failed_call import _pendulum

    from optimize.solve import nlp_solver

    armed = []

    @contextlib.contextmanager
    def recording(limit_s, grace_s=None):
        armed.append(limit_s)
        yield

    monkeypatch.setattr(nlp_solver, "hard_stop", recording)
    _, ocp, w0, p, bounds = _pendulum("ipopt", "collocation")
    assert nlp_solver.run(ocp, w0, p, bounds, warm=False).success
    assert armed == [ocp.options.solver.call_time_limit_s]


def test_a_hung_call_in_bench_size_s_solves_stops_them_naming_it():
    # solve_tasks (bench size, bench aep --refine): the loss is an InputError (exit 2),
    # its stored solves kept for a re-run
    from optimize.service import SolveTask, solve_tasks
    from optimize.service.executors import WorkerLost

    tasks = [SolveTask(BOUNDED, Scenario.of_kind("elec-lim", w)) for w in (7.0, 10.0)]
    t0 = time.monotonic()
    with pytest.raises(WorkerLost, match="taken to hang") as err:
        solve_tasks(tasks, workers=1, backend=HangingBackend())
    assert time.monotonic() - t0 < 60 and err.value.label == "WORKER LOST"


def test_a_hung_call_on_a_dask_worker_of_its_own_fails_its_scenario():
    # a worker process of one thread ends itself at the hard stop; its nanny starts it
    # again and the scheduler fails the task once past its allowed failures (0 here)
    distributed = pytest.importorskip("distributed")
    kinds = ("elec-free", "elec-lim")
    tasks = SweepTasks(BOUNDED, plan_graph(WINDS, kinds), backend=HangingBackend(),
                       selected=kinds)
    dask = pytest.importorskip("dask")
    with (dask.config.set({"distributed.scheduler.allowed-failures": 0}),
          distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                   dashboard_address=None) as cluster,
          open_executor(scheduler=cluster.scheduler_address) as handle):
        t0 = time.monotonic()
        result = run_sweep(tasks, handle, show_progress=False)
    assert time.monotonic() - t0 < 120 and result.lost is None
    by_name = {o.name: o for o in result.outcomes}
    assert by_name["elec-lim-10.0"].status.startswith("worker error: KilledWorker")
    # the sweep went on: every other scenario converged, exact, but for one that the
    # scheduler had already handed to the dying worker (queued behind the hung task, it
    # fails with it, as Dask counts it among the tasks that worker died running); stage 0
    # (elec-free) ended before the hang
    for o in result.outcomes:
        if o.name == "elec-lim-10.0":
            continue
        if o.kind == "elec-lim" and not o.success:
            assert o.status.startswith("worker error: KilledWorker"), o.status
            continue
        assert o.success and o.result.avg_p_elec_w == pytest.approx(
            SCALE_W * (exact_root(CUT_IN_M_S[o.kind]) - exact_root(o.wind_speed_m_s)),
            rel=1e-9)
    assert sum(o.success for o in result.outcomes) >= len(result.outcomes) - 3
