"""Continuation with step control: from a converged solution of one problem to the
optimum of another, through intermediate problems when the direct warm solve is dear.

A warm start carries the NLP parameters it solved (:attr:`Solution.p`: the wind speed
and the objective's weights) and whether the drive limits bounded it. Between it and the
scenario to solve lies a straight path in ``s`` from 0 to 1 (:class:`StepPath`):

* the NLP parameters move linearly (the wind speed; the objective's weights, so a switch
  of objective passes through blends of the electrical and mechanical average powers);
* a bound the scenario loosens is loosened at once (the start stays feasible); a bound
  it tightens (the drive limits switched on) starts at the start's own value and closes
  linearly onto the scenario's.

:func:`step_towards` solves the scenario directly, capped at :data:`STEP_ITERATIONS`;
when that fails or runs into the cap it halves the step, solving intermediate points of
the path (each warm from the last converged one, each capped) and doubling the step again
after each success, down to :data:`MIN_STEP` of the path and within :data:`STEP_BUDGET`
iterations on the way. The intermediate points are not results: they come back with what
they cost (``intermediates``), apart from the final solve at the scenario.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from optimize.problem.ocp import Bounds, Ocp
from optimize.solve import nlp_solver
from optimize.solve.result import Solution

log = logging.getLogger(__name__)

#: iterations a solve on the path may take before its step is halved: well above the
#: warm solves of the shipped systems' sweeps (paper kite 19-47, AP2 19-73, MegAWES
#: 22-121 on 4:14:2; benchmarks/README.md, foreign kites). At 75 the AP2 sweep stepped
#: where a direct solve needed 76-150, and spent 54 % more iterations in all
STEP_ITERATIONS = 150
#: the smallest step tried, as a fraction of the path
MIN_STEP = 1.0 / 16.0
#: iterations on the way (the capped tries and the intermediate points) after which the
#: stepping gives up: a scenario that far is not a neighbour's (the caller's fallbacks,
#: its other sources and the cold retry, take over)
STEP_BUDGET = 3 * STEP_ITERATIONS


@dataclass(frozen=True)
class StepPath:
    """The straight way from a start's problem to a scenario's.

    Attributes
    ----------
    p0, p1 : numpy.ndarray
        The NLP parameters of the start and of the scenario.
    bounds1 : tuple of numpy.ndarray
        The scenario's scaled ``lbw, ubw, lbg, ubg``.
    relax : tuple of numpy.ndarray
        Per bound of ``bounds1``, how far it is moved outwards at ``s = 0`` to hold the
        start (0 where the scenario's bound holds it already).
    """

    p0: np.ndarray
    p1: np.ndarray
    bounds1: Bounds
    relax: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

    @classmethod
    def between(cls, ocp: Ocp, start: Solution, p1: np.ndarray, bounds1: Bounds) -> StepPath:
        """The path from ``start`` (which knows its parameters) to ``(p1, bounds1)``."""
        w0, g0 = start.w, ocp.constraint_values(start.w, start.p)
        lbw, ubw, lbg, ubg = bounds1
        relax = (np.maximum(lbw - w0, 0.0), np.maximum(w0 - ubw, 0.0),
                 np.maximum(lbg - g0, 0.0), np.maximum(g0 - ubg, 0.0))
        return cls(start.p, p1, bounds1, relax)

    def at(self, s: float) -> tuple[np.ndarray, Bounds]:
        """The NLP parameters and the scaled bounds at ``s`` in [0, 1]."""
        lbw, ubw, lbg, ubg = self.bounds1
        rw_lo, rw_hi, rg_lo, rg_hi = (r * (1.0 - s) for r in self.relax)
        return (self.p0 + s * (self.p1 - self.p0),
                (lbw - rw_lo, ubw + rw_hi, lbg - rg_lo, ubg + rg_hi))


@dataclass(frozen=True)
class Stepped:
    """The outcome of :func:`step_towards`.

    Attributes
    ----------
    final : RawSolve or None
        The converged solve at the scenario (``s = 1``); None when no step size
        down to :data:`MIN_STEP` got there within :data:`STEP_BUDGET`.
    last : RawSolve
        The last solver call (``final`` when it converged).
    intermediates : tuple of dict
        Every other solver call on the way, in order: ``step`` (its ``s``),
        ``status``, ``success``, ``iterations``, ``wall_time_s``, ``cpu_time_s``; the
        converged ones at ``s < 1`` are the intermediate points.
    """

    final: nlp_solver.RawSolve | None
    last: nlp_solver.RawSolve
    intermediates: tuple[dict, ...]


def _call(ocp: Ocp, start: Solution | nlp_solver.RawSolve, p: np.ndarray, bounds: Bounds
          ) -> nlp_solver.RawSolve:
    """One capped warm solve of ``(p, bounds)`` from ``start``."""
    return nlp_solver.run(ocp, start.w, p, bounds, warm=True, lam_x0=start.lam_x,
                       lam_g0=start.lam_g, setting=nlp_solver.Setting(max_iter=STEP_ITERATIONS))


def _entry(s: float, raw: nlp_solver.RawSolve) -> dict:
    return {"step": s, "status": raw.status, "success": raw.success,
            "iterations": raw.iterations, "wall_time_s": raw.wall_time_s,
            "cpu_time_s": raw.cpu_time_s}


def step_towards(ocp: Ocp, start: Solution, p1: np.ndarray, bounds1: Bounds,
                 name: str = "") -> Stepped:
    """Solve ``(p1, bounds1)`` from ``start`` with step control (module docstring).

    Parameters
    ----------
    ocp : Ocp
    start : Solution
        A converged solution that knows its NLP parameters (``start.p``) and its
        configuration's bounds (it satisfies them).
    p1 : numpy.ndarray
        The scenario's NLP parameters.
    bounds1 : tuple of numpy.ndarray
        The scenario's scaled bounds.
    name : str
        The scenario's name, for the log.
    """
    path = StepPath.between(ocp, start, p1, bounds1)
    current: Solution | nlp_solver.RawSolve = start
    done, step, tried = 0.0, 1.0, []
    while step >= MIN_STEP and sum(t["iterations"] for t in tried) < STEP_BUDGET:
        s = min(1.0, done + step)
        p, bounds = path.at(s)
        raw = _call(ocp, current, p, bounds)
        log.info("%s: step to s = %.4g of the way %s, %d it", name, s, raw.status,
                 raw.iterations)
        if raw.success and s == 1.0:
            return Stepped(raw, raw, tuple(tried))
        tried.append(_entry(s, raw))
        if raw.success:
            done, current, step = s, raw, min(2.0 * step, 1.0 - s)
        else:
            step /= 2.0
    return Stepped(None, raw, tuple(tried))
