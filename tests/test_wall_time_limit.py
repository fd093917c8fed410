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
    ("ipopt", "collocation"), ("ipopt", "condensed"), ("fatrop", "condensed")])
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
    # the point fatrop returned
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
