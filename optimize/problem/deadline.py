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
"""

from __future__ import annotations

import math
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
#: how the status of a solve stopped at its deadline begins
WALL_STATUS = "Wall_Time_Limit"

_local = threading.local()


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
