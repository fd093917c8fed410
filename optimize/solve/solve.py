"""Solve one scenario warm-started from a neighbouring solution (a *warm start*; a
problem's first solve, with no solution at hand, is a *cold start*:
:func:`optimize.solve.starts.cold.start`).

Typical use (the sweep builds the OCP once and chains warm starts; every other start is
in :mod:`optimize.solve.starts`)::

    dae = kite_dae()
    ocp = build_ocp(dae, load_power_model(path), OcpOptions(Discretization(n_intervals=40)))
    res = start(ocp, Scenario(7.0, "mechanical", False))  # optimize.solve.starts.cold
    res2 = solve(ocp, Scenario(7.0, "electrical", False), res.warm)
"""

from __future__ import annotations

import logging

import numpy as np

from optimize.problem.deadline import COLD_START_CALLS, deadline
from optimize.problem.ocp import Bounds, Ocp
from optimize.problem.scenario import Scenario
from optimize.solve import nlp_solver
from optimize.solve.result import OcpResult, Solution, make_result
from optimize.solve.starts.continuation import step_towards
from optimize.solve.starts.predictor import predict

log = logging.getLogger(__name__)

def solve(
    ocp: Ocp, scenario: Scenario, warm_start: Solution, retry_cold: bool = True,
    period_s: float | None = None,
) -> OcpResult:
    """Solve ``scenario`` warm-started from ``warm_start``.

    A start that solved this very problem (the same NLP parameters and drive limits,
    the period free: :func:`at_optimum`) is first checked: when it is an optimum to the
    tolerance, the check (stage ``"check"``, at most two iterations) is the solve.
    The warm start passes the primal vector and both multiplier vectors with
    IPOPT's ``warm_start_init_point`` and a small ``mu_init`` (fatrop takes the
    primal vector and the small ``mu_init``; it starts no multipliers). A start that
    knows the problem it solved (:attr:`Solution.p`) is solved with step control: capped,
    and through intermediate points of the way from its problem to the scenario's when
    the direct solve is dear (:mod:`optimize.solve.starts.continuation`); with the
    solver options' ``predictor_step``, moved first along the tangent to the
    scenario's parameters (:mod:`optimize.solve.starts.predictor`; stage
    ``"predicted"``). If that fails and ``retry_cold`` is set, the same primal point
    is tried once more with the default (cold) barrier settings; both calls count in
    the result. A warm solve, its steps and its cold retry together, runs at most
    :data:`~optimize.problem.deadline.COLD_START_CALLS` times a call's limit, as a cold
    start does (its calls past that are not made: the solve fails with the status
    :data:`~optimize.problem.deadline.WALL_STATUS`).

    Parameters
    ----------
    ocp : Ocp
        Built by :func:`optimize.problem.ocp.build_ocp`.
    scenario : Scenario
        Wind speed, objective and drive limits.
    warm_start : Solution
        ``OcpResult.warm`` of a previous solve of the same ``ocp`` layout (a problem's
        first solve is :func:`optimize.solve.starts.cold.start`'s).
    retry_cold : bool
        Retry a failed warm solve with cold barrier settings.
    period_s : float, optional
        Hold the period at this value [s] (a start elsewhere on the period axis,
        :mod:`optimize.service.period_scan`); None leaves it free within its bounds.

    Raises
    ------
    ValueError
        If ``warm_start`` comes from a different discretization.
    """
    if (warm_start.n_intervals, warm_start.degree) != (ocp.n_intervals, ocp.coll.degree):
        raise ValueError(
            f"warm start has N={warm_start.n_intervals}, degree {warm_start.degree}; "
            f"the OCP has N={ocp.n_intervals}, degree {ocp.coll.degree}"
        )
    if warm_start.w.size != ocp.layout.n_w:
        raise ValueError(f"warm start has {warm_start.w.size} variables; the OCP's "
                         f"{ocp.layout.name} layout has {ocp.layout.n_w} (carry it over with "
                         "optimize.solve.result.carry_over)")
    if warm_start.lam_g.size != ocp.layout.n_g:
        raise ValueError(f"warm start has {warm_start.lam_g.size} constraint multipliers; the "
                         f"OCP has {ocp.layout.n_g} rows (another OCP's solution: carry it over "
                         "with optimize.solve.result.carry_over)")
    with deadline(COLD_START_CALLS * ocp.options.solver.call_time_limit_s):
        return _solve_warm(ocp, scenario, warm_start, retry_cold, period_s)


def _solve_warm(ocp: Ocp, scenario: Scenario, warm_start: Solution, retry_cold: bool,
                period_s: float | None) -> OcpResult:
    """:func:`solve` from ``warm_start``, checked to be of this OCP's layout."""
    bounds = ocp.bounds(drive_limits=scenario.drive_limits, fix_fictitious=True,
                        period_s=period_s)
    p = ocp.params(scenario.parameters, scenario.weights)
    stages = []
    if (period_s is None and ocp.options.solver.solver == "ipopt"
            and may_solve(ocp, warm_start, p, bounds, scenario.drive_limits)):
        raw = at_optimum(ocp, warm_start, p, bounds)
        stages.append(raw.stage("check"))
        if raw.success:
            log.info("%s: its start is an optimum of its problem", scenario.name)
            return make_result(ocp, scenario, raw, p, bounds, stages)
    raw, stage, intermediates = _warm(ocp, warm_start, p, bounds, period_s, scenario.name)
    stages += [stage] if stage else []
    if not raw.success and retry_cold:
        raw = nlp_solver.run(ocp, warm_start.w, p, bounds, warm=False)
        stages.append(raw.stage("retry-cold"))
        log.info("%s retry %-22s %4d it %6.1f s (cpu %.1f s)", scenario.name, raw.status,
                 raw.iterations, raw.wall_time_s, raw.cpu_time_s)
    return make_result(ocp, scenario, raw, p, bounds, stages, intermediates=intermediates)


def _warm(ocp: Ocp, warm: Solution, p: np.ndarray, bounds: Bounds, period_s: float | None,
          name: str) -> tuple[nlp_solver.RawSolve, dict | None, tuple[dict, ...]]:
    """The warm solve of ``(p, bounds)`` from ``warm``: with step control when ``warm``
    knows its problem and the period is free (no stage of its own when no step reached
    the scenario: every try is then on the way), else one solve (predicted along the
    tangent with the options' ``predictor_step``). Returns the last solver call, its
    stage and the solves on the way."""
    if period_s is None and warm.p is not None and ocp.options.solver.predictor_step <= 0:
        stepped = step_towards(ocp, warm, p, bounds, name)
        raw, way = stepped.last, stepped.intermediates
        stage = raw.stage("warm") if stepped.final is not None else None
    else:
        name, w0, lam_x0, lam_g0, predict_s = _predicted(ocp, warm, p, bounds)
        raw, way = nlp_solver.run(ocp, w0, p, bounds, warm=True, lam_x0=lam_x0,
                               lam_g0=lam_g0), ()
        stage = raw.stage(name, predict_s)
    log.info("%s %-22s %4d it %6.1f s (cpu %.1f s), %d solves on the way (%d it)",
             name, raw.status, raw.iterations, raw.wall_time_s, raw.cpu_time_s,
             len(way), sum(s["iterations"] for s in way))
    return raw, stage, way


#: the check of a start that may be an optimum already: IPOPT with the barrier and the
#: bound pushes below the tolerance and at most two iterations (from the scenario's own
#: optimum it converges at iteration 0 or 1; with the warm options' barrier of 1e-4 it
#: climbs back down in 18-19 iterations)
AT_OPTIMUM, AT_OPTIMUM_PUSH = nlp_solver.Setting(mu_init=1e-7, max_iter=2), 1e-9


#: how far [scaled units] a start may sit outside a bound and still count as within it
#: (:func:`within_bounds`): the solver's own bound and constraint tolerances are 1e-8
WITHIN_TOL = 1e-6


def may_solve(ocp: Ocp, warm: Solution, p: np.ndarray, bounds: Bounds,
              drive_limits: bool) -> bool:
    """Whether ``warm`` may be an optimum of the problem ``(p, bounds)`` with or without
    ``drive_limits``: it solved the same NLP parameters (those it knows it solved,
    :attr:`Solution.p`), under the same drive limits, or under others where its point
    lies within ``bounds`` (limits that do not bind it: the paper kite's drive limits at
    4 m/s, where the free kind's optimum is the limited kind's). Only then is the
    convergence check (:func:`at_optimum`) worth its two iterations."""
    if warm.p is None or warm.p.shape != p.shape or not np.array_equal(warm.p, p):
        return False
    return warm.drive_limits == drive_limits or within_bounds(ocp, warm, p, bounds)


def within_bounds(ocp: Ocp, warm: Solution, p: np.ndarray, bounds: Bounds) -> bool:
    """Whether ``warm``'s point satisfies ``bounds`` (scaled) at ``p``, to :data:`WITHIN_TOL`."""
    lbw, ubw, lbg, ubg = bounds
    g = ocp.constraint_values(warm.w, p)
    return bool(np.all(warm.w >= lbw - WITHIN_TOL) and np.all(warm.w <= ubw + WITHIN_TOL)
                and np.all(g >= lbg - WITHIN_TOL) and np.all(g <= ubg + WITHIN_TOL))


def at_optimum(ocp: Ocp, warm: Solution, p: np.ndarray, bounds: Bounds) -> nlp_solver.RawSolve:
    """The convergence check of ``warm`` on the problem ``(p, bounds)``: a solve of at
    most two iterations that succeeds when ``warm`` is an optimum there to the tolerance."""
    return nlp_solver.run(ocp, warm.w, p, bounds, warm=True, lam_x0=warm.lam_x,
                       lam_g0=warm.lam_g, bound_push=AT_OPTIMUM_PUSH, setting=AT_OPTIMUM)


def _predicted(ocp: Ocp, warm: Solution, p: np.ndarray, bounds: Bounds
               ) -> tuple[str, np.ndarray, np.ndarray, np.ndarray, float]:
    """The warm start of a solve at ``p`` and the seconds it took: ``("warm", the
    neighbour's vectors, 0)``, or, with the solver options' ``predictor_step`` above 0
    and a neighbour that knows its own parameters (:attr:`Solution.p`) and they differ,
    ``("predicted", the vectors moved along the tangent, its time)``
    (:func:`optimize.solve.starts.predictor.predict`)."""
    step = ocp.options.solver.predictor_step
    if (step <= 0 or warm.p is None or warm.p.shape != p.shape
            or np.array_equal(warm.p, p)):
        return "warm", warm.w, warm.lam_x, warm.lam_g, 0.0
    before = ocp.bounds(drive_limits=bool(warm.drive_limits), fix_fictitious=True,
                        period_s=None)
    w, lam_x, lam_g, tg = predict(ocp, warm.w, warm.lam_x, warm.lam_g, warm.p, p, before,
                                  bounds, step=step)
    return "predicted", w, lam_x, lam_g, tg.time_s
