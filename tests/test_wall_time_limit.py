"""A solve ends within a stated time, its status naming why (optimize/problem/deadline.py):
one solver call runs at most SolverOptions.call_time_limit_s (`--call-time-limit`, default
CALL_WALL_LIMIT_S; IPOPT's max_wall_time; the condensed NLP's evaluations fail quietly
past it, which ends fatrop's call too), a cold start COLD_START_CALLS times as long, and
no call is made past the deadline.

Was: a condensed homotopy stage whose trial points failed the intervals' Newton solves
(evaluation errors) ran IPOPT to its 1000 iterations at 0.5 s each, and a 90 degC winding
limit with the condensed formulation neither finished nor failed within 900 s. The
problem here is the exact pendulum of test_condensed_transcription, which each solver
solves in well under the limits; a limit of a few milliseconds stops every one of them."""

from __future__ import annotations

import time

import numpy as np
import pytest
from point_mass_model import solved_pendulum

from optimize.problem import deadline


def _run(solver: str, transcription: str, **options):
    return solved_pendulum(solver, transcription, **options)[2]


def test_the_deadline_nests_and_passes():
    assert not deadline.passed()
    with deadline.deadline(60.0):
        assert not deadline.passed()
        with deadline.deadline(1e-6):  # the earlier of the two holds inside
            time.sleep(1e-3)
            assert deadline.passed()
        assert not deadline.passed()
        with deadline.deadline(1e6):  # a later one does not extend it
            assert not deadline.passed()
    assert not deadline.passed()


def test_no_call_is_made_past_the_deadline():
    with deadline.deadline(1e-6):
        time.sleep(1e-3)
        t0 = time.perf_counter()
        raw = _run("ipopt", "collocation")
    assert time.perf_counter() - t0 < 1.0  # the NLP's assembly, no solve
    assert not raw.success and raw.iterations == 0
    assert raw.status.startswith(f"{deadline.WALL_STATUS}: not run")


@pytest.mark.parametrize(("solver", "transcription"), [
    ("ipopt", "collocation"), ("ipopt", "condensed"), ("fatrop", "condensed"),
    ("fatrop", "collocation")])
def test_a_call_past_its_limit_ends_with_a_status_that_says_so(solver, transcription, capfd):
    assert _run(solver, transcription).success  # within the stated limits: solved
    t0 = time.perf_counter()
    raw = _run(solver, transcription, call_time_limit_s=1e-3)
    assert time.perf_counter() - t0 < 30.0
    assert not raw.success
    assert raw.status.startswith(f"{deadline.WALL_STATUS}: stopped after "), raw.status
    assert "the solver said" in raw.status
    # was: CasADi printed the condensed callback's TimeoutError traceback and every input
    # of every enclosing function (60 kB here), or a warning that it could not evaluate
    # the point fatrop returned; fatrop on the collocation had no limit at all
    err = capfd.readouterr().err
    assert "Traceback" not in err and err == "", err[:2000]


def test_a_condensed_call_stopped_mid_solve_is_quiet_and_keeps_its_iterate(capfd):
    """The deadline passes after the first Newton solves: the points asked for later
    are refused (no interval solved), the iterate is still answered."""
    from optimize.problem.transcriptions import condensed_derivatives as cd

    solve = cd.IntervalCache._point
    seen = []

    def slow_after_two(self, w, p):  # the deadline passes at the third point
        seen.append(1)
        if len(seen) == 3:
            time.sleep(0.05)
        return solve(self, w, p)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(cd.IntervalCache, "_point", slow_after_two)
        for solver in ("ipopt", "fatrop"):
            seen.clear()
            raw = _run(solver, "condensed", call_time_limit_s=0.04)
            assert len(seen) > 3  # asked for after the deadline, refused
            assert not raw.success and raw.status.startswith(deadline.WALL_STATUS), raw.status
    assert capfd.readouterr().err == ""


def test_the_call_limit_is_an_option_and_a_cold_start_takes_four_of_them():
    from optimize.problem.options import SolverOptions

    assert SolverOptions().call_time_limit_s == deadline.CALL_WALL_LIMIT_S == 150.0
    assert deadline.COLD_START_CALLS == 4
    with pytest.raises(ValueError, match="--call-time-limit"):
        SolverOptions(call_time_limit_s=0.0)


@pytest.mark.parametrize("argv", [
    ["optimize", "--wind-grid", "7", "--scenarios", "elec-lim"],
    ["size", "--scales", "1", "--wind-grid", "7,8", "--weibull-k", "2", "--mean-speed", "6"],
    ["aep", "--refine", "--weibull-k", "2", "--mean-speed", "6"],
])
@pytest.mark.parametrize("limit", ["0", "-5", "nan"])
def test_every_command_that_solves_refuses_a_limit_that_is_not_positive(
        argv, limit, tmp_path, capsys, monkeypatch):
    # bench size and bench aep --refine ran every solve at the 150 s default: they take
    # the option now, the one definition of bench optimize's, refused the same way
    from drivebench.cli import main

    monkeypatch.chdir(tmp_path)
    assert main([*argv, "--call-time-limit", limit, "--out", "o", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--call-time-limit" in err and "Traceback" not in err, err
    assert not (tmp_path / "o").exists()


def test_the_limit_reaches_the_solves_of_size_and_aep_refine(tmp_path, monkeypatch):
    from types import SimpleNamespace

    import energy.refine as refine
    import energy.size_command as size_command
    from energy.site import Weibull
    from optimize.problem.options import OcpOptions
    from optimize.sweep_options import SolverChoice
    from optimize.system.system_file import load_system

    # bench size: each candidate's problem, so the stored solves' keys differ
    system = load_system()
    seen = {}

    class Stop(Exception):
        pass

    def run_sizing(cands, *args, call_time_limit_s, **kwargs):
        seen["size"] = call_time_limit_s
        seen["problem"] = cands[0].problem(10, 4, system, call_time_limit_s)
        seen["default"] = cands[0].problem(10, 4, system)
        raise Stop

    monkeypatch.setattr(size_command, "run_sizing", run_sizing)
    with pytest.raises(Stop):
        size_command.run_size(Weibull.from_mean(2.0, 6.0), grid=size_command.SizingGrid(
            (1.0,), (), (7.0, 8.0), 0.02, 0, False), solver=SolverChoice(10, 4,
                                                                    call_time_limit_s=400.0),
            out=tmp_path / "size_out")
    assert seen["size"] == 400.0
    assert seen["problem"].options.solver.call_time_limit_s == 400.0
    assert seen["default"].options.solver.call_time_limit_s == deadline.CALL_WALL_LIMIT_S
    assert seen["default"].key != seen["problem"].key  # a stored solve is another's

    # bench aep --refine: the sweep's options, the limit replaced
    def kind_task(kind, model, options, *args):
        seen["refine"] = options.solver.call_time_limit_s
        raise Stop

    monkeypatch.setattr(refine, "options_from_manifest", lambda m, p: OcpOptions())
    monkeypatch.setattr(refine, "system_from_manifest", lambda m, p: None)
    monkeypatch.setattr(refine, "sweep_starts", lambda run, n: {})
    monkeypatch.setattr(refine, "KindTask", kind_task)
    curve = SimpleNamespace(wind_speed_m_s=np.array([6.0, 8.0]), p_elec_w=np.zeros(2),
                            p_mech_w=np.zeros(2))
    run = SimpleNamespace(folder=tmp_path, manifest={}, drive_model_sha256=None,
                          curves={"elec-lim": curve})
    model = SimpleNamespace(sha256="")
    with pytest.raises(Stop):
        refine.refine_run(run, model, Weibull.from_mean(2.0, 6.0), tmp_path / "s",
                          call_time_limit_s=500.0)
    assert seen["refine"] == 500.0


def test_a_warm_solve_with_its_steps_and_retry_ends_within_four_limits(monkeypatch):
    """Every call fails just inside the call's limit: the warm solve's steps towards the
    scenario and its cold retry stop at four limits, as a cold start does. Was: no bound
    but each call's (fatrop on the condensed NLP, whose calls failed at the limit, ran a
    4-scenario sweep for more than 13 minutes at a 30 s limit)."""
    from system_fixtures import system_for

    from optimize.model.kite_model import kite_dae
    from optimize.paper_model import paper_model
    from optimize.problem.ocp import build_ocp
    from optimize.problem.options import Discretization, OcpOptions, SolverOptions
    from optimize.problem.scenario import Scenario
    from optimize.solve import nlp_solver
    from optimize.solve.result import Solution
    from optimize.solve.solve import solve
    from optimize.solve.starts.fill import part_start

    limit_s, call_s = 0.5, 0.4
    ocp = build_ocp(kite_dae(), paper_model(), OcpOptions(
        Discretization(n_intervals=4), solver=SolverOptions(call_time_limit_s=limit_s)),
        system=system_for())
    mech = Scenario(7.0, "mechanical", False)
    g = part_start(ocp, ocp.loop.period_s, mech.parameters)
    w0 = ocp.pack(g["x"], g["z"], g["u"], g["fict"], ocp.loop.period_s)
    warm = Solution(w0, np.zeros(ocp.layout.n_w), np.zeros(ocp.layout.n_g), 4,
                    ocp.coll.degree, p=ocp.params(mech.parameters, mech.weights),
                    drive_limits=False)
    calls = []

    def failing(nlpsol, w, *_args):  # a call that fails just inside its limit
        calls.append(time.perf_counter())
        time.sleep(call_s)
        return nlp_solver.RawSolve(np.asarray(w, dtype=float), np.zeros(ocp.layout.n_w),
                                   np.zeros(ocp.layout.n_g), np.nan,
                                   "Restoration_Failed", False, 5, call_s, 0.0)

    monkeypatch.setattr(nlp_solver, "solver", lambda *args, **kwargs: None)
    monkeypatch.setattr(nlp_solver, "_call", failing)
    t0 = time.perf_counter()
    res = solve(ocp, Scenario(7.0, "electrical", True), warm)
    assert not res.success
    assert res.status.startswith(f"{deadline.WALL_STATUS}: not run"), res.status
    # no call starts past the solve's four limits (the last one ends at most a call later)
    assert calls[-1] - t0 < deadline.COLD_START_CALLS * limit_s
    assert time.perf_counter() - t0 < deadline.COLD_START_CALLS * limit_s + call_s + 1.0
