"""How long a solve may run: a wall-time deadline of the calling thread.

One NLP solver call may run ``SolverOptions.call_time_limit_s`` seconds
(:data:`CALL_WALL_LIMIT_S` unless ``--call-time-limit`` says otherwise), and a cold start
(the stored guess, the homotopy and its fallbacks together) or a warm solve (its steps and
its cold retry) :data:`COLD_START_CALLS` times as long
(:func:`optimize.solve.starts.cold.start`, :func:`optimize.solve.solve.solve`). IPOPT
stops itself there (its ``max_wall_time``); past the deadline the condensed NLP solves no
new point: its evaluations there fail quietly
(:class:`optimize.problem.transcriptions.condensed_derivatives.IntervalCache`), which
ends any solver's call (fatrop has no time limit of its own); on the collocation
fatrop's constraint Jacobian does the same
(:class:`optimize.problem.transcriptions.gate.Gated`); a call asked for after it is not
made (:func:`optimize.solve.nlp_solver.run`). A solve stopped so fails with the status
:data:`WALL_STATUS` and what its last call said.

A call that does not return at all is ended with its process, in a worker of the local
process pool (:func:`pool_worker`; :func:`hard_stop`): fatrop can loop for good inside one
iteration, where no evaluation asks for the time (its inertia correction has no cap: the
paper kite's condensed NLP at 10 intervals, ``--call-time-limit 30``, ran 4 minutes in one
call before it was stopped). The driver then stops the run with what finished
(:class:`optimize.service.executors.WorkerLost`).
"""

from __future__ import annotations

import faulthandler
import math
import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

#: the default of the longest one solver call may run [s] (successful cold starts measured
#: at most 62 s in all with IPOPT, AP2 condensed, and 181 s with fatrop, MegAWES condensed,
#: each in several calls: benchmarks/README.md)
CALL_WALL_LIMIT_S = 150.0
#: how many calls' limits a cold start or a warm solve may run, all its calls together
COLD_START_CALLS = 4
#: how many calls' limits one scenario's solver runs may take in all (its warm attempts and
#: cold start, its retries, its re-solves; :class:`optimize.service.solves.Solves`): no run
#: starts past them, so a sweep of S scenarios solves at most S times as long
SCENARIO_CALLS = 8
#: how the status of a solve stopped at its deadline begins
WALL_STATUS = "Wall_Time_Limit"
#: a solver call still running :data:`HARD_STOP_CALLS` times its limit and
#: :data:`HARD_STOP_GRACE_S` after it began is taken to hang, and its worker process ends
#: (:func:`hard_stop`): a call ends at its limit, give or take one iteration
HARD_STOP_CALLS = 2
HARD_STOP_GRACE_S = 60.0

_local = threading.local()
#: whether this process may end itself at a hung call's hard stop (:func:`pool_worker`)
_may_stop = {"armed": False, "sink": None}


@contextmanager
def deadline(seconds: float) -> Iterator[None]:
    """While open, this thread's deadline is ``seconds`` from now, or the one already set
    when that comes first."""
    before = getattr(_local, "at", math.inf)
    _local.at = min(before, time.monotonic() + seconds)
    try:
        yield
    finally:
        _local.at = before


def passed() -> bool:
    """Whether this thread's deadline has passed (never without one)."""
    return time.monotonic() > getattr(_local, "at", math.inf)


def hard_stop_s(limit_s: float, grace_s: float = HARD_STOP_GRACE_S) -> float:
    """When a solver call of limit ``limit_s`` [s] is taken to hang [s after it began]."""
    return HARD_STOP_CALLS * limit_s + grace_s


def pool_worker(parent_pid: int) -> None:
    """Process initializer of the local pool's workers: the process ends with
    ``parent_pid`` (:func:`kernel.lifetime.die_with_parent`) and at a hung solver call's
    hard stop (:func:`hard_stop`). Light to import: a spawned worker imports the module of
    its initializer first."""
    from kernel.lifetime import die_with_parent

    die_with_parent(parent_pid)
    arm_hard_stop()


def arm_hard_stop() -> None:
    """Let this process end itself at a hung solver call's hard stop (:func:`hard_stop`):
    a worker process of its own that runs one task at a time (the local pool's, a Dask
    worker's of one thread), never the command's."""
    _may_stop["armed"] = True


@contextmanager
def hard_stop(limit_s: float, grace_s: float = HARD_STOP_GRACE_S) -> Iterator[None]:
    """While open, a solver call of limit ``limit_s`` [s] runs: in a worker process that
    runs one task at a time (:func:`arm_hard_stop`), the process exits (status 1, from a
    watchdog thread that needs no lock of the interpreter,
    :func:`faulthandler.dump_traceback_later`) when the call is still running
    :func:`hard_stop_s` after it began (``grace_s`` in place of
    :data:`HARD_STOP_GRACE_S`: the tests' stand-in solvers). Elsewhere (the
    command's own process, an in-process cluster, the tests) and with no limit
    (``--call-time-limit inf``) nothing is armed."""
    armed = _may_stop["armed"] and math.isfinite(limit_s)
    if armed:
        if _may_stop["sink"] is None:  # the watchdog's traceback is nobody's to read
            _may_stop["sink"] = open(os.devnull, "w")  # noqa: SIM115 - open for good
        faulthandler.dump_traceback_later(hard_stop_s(limit_s, grace_s), exit=True,
                                          file=_may_stop["sink"])
    try:
        yield
    finally:
        if armed:
            faulthandler.cancel_dump_traceback_later()
