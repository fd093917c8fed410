"""The condensed method: multiple shooting with each interval's collocation solved inside
it (:mod:`optimize.problem.transcriptions.condensed_nlp`), built beside the collocation's
general layout, in which its starts and solutions are read and written
(:mod:`optimize.problem.transcriptions.condensed_multipliers`).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.collocation import Collocation
from optimize.problem.interface import CycleFormulation
from optimize.problem.options import Discretization, SolverOptions
from optimize.problem.transcriptions.codegen import compiler
from optimize.problem.transcriptions.collocation import full_derivatives
from optimize.problem.transcriptions.condensed_derivatives import (
    Answered,
    IntervalCache,
    condensed_derivatives,
)
from optimize.problem.transcriptions.condensed_multipliers import to_condensed, to_full
from optimize.problem.transcriptions.condensed_nlp import CondensedNlp, condensed_nlp
from optimize.problem.transcriptions.layouts import general_layout
from optimize.problem.transcriptions.method import Call, SolverNlp, compile_fn
from optimize.problem.transcriptions.structure import Transcription

log = logging.getLogger(__name__)


def condensed(ocp: Any) -> CondensedNlp:
    """The OCP's condensed NLP and its derivatives (built once, cached on the OCP as
    ``"condensed"`` and ``"condensed_derivatives"``)."""
    if "condensed" not in ocp.solvers:
        t0 = time.perf_counter()
        compile_with = compile_fn(ocp)
        # CasADi generates C code for its dense Newton method, not for the sparse one
        rootfinder = "fast_newton" if compile_with and compiler() else "newton"
        c = condensed_nlp(ocp.formulation, ocp.coll, ocp.transcription, rootfinder)
        derivs, callbacks = condensed_derivatives(c, compile_with)
        ocp.solvers["condensed"] = c
        ocp.solvers["condensed_derivatives"] = derivs
        # the callbacks into the interval cache live as long as the solvers that call them
        ocp.solvers["condensed_callbacks"] = callbacks
        ocp.solvers["condensed_cache"] = callbacks[0].owner
        ocp.solvers["condensed_nlp_grad"] = _nlp_grad(derivs, callbacks[0].owner)
        log.info("built the condensed NLP (%s%s): %d variables, %d constraints in %.1f s",
                 rootfinder, ", compiled" if compile_with else "", c.n_w, c.n_g,
                 time.perf_counter() - t0)
    return ocp.solvers["condensed"]


def _nlp_grad(d: Any, cache: IntervalCache) -> Answered:
    """The NLP's objective, rows and Lagrangian gradient (in the parameters structurally
    zero: their multipliers are not computed), as CasADi evaluates them at a solver's
    solution: every point answered, past the deadline too."""
    grad_x = d.lam_f * d.grad + ca.mtimes(d.jac.T, d.lam_g)
    return Answered(ca.Function("nlp_grad", [d.x, d.p, d.lam_f, d.lam_g],
                                [d.f, d.g, grad_x, ca.MX(d.p.shape[0], 1)],
                                ["x", "p", "lam_f", "lam_g"],
                                ["f", "g", "grad_gamma_x", "grad_gamma_p"]), cache)


class CondensedMethod:
    """Multiple shooting over the collocation (a
    :class:`optimize.problem.transcriptions.method.Method`)."""

    name = "condensed"

    def transcribe(self, form: CycleFormulation, disc: Discretization, coll: Collocation,
                   solver: SolverOptions) -> Transcription:
        """The collocation's general layout (the condensed NLP is built beside it, once
        a solver needs it, :func:`condensed`)."""
        return general_layout(form, disc, coll)

    def solver_nlp(self, ocp: Any, solver: str) -> SolverNlp:
        """The condensed NLP as ``solver`` runs it.

        Its objective and rows come from the intervals solved once per point
        (:class:`optimize.problem.transcriptions.condensed_derivatives.IntervalCache`),
        reached through callbacks CasADi cannot differentiate. So every derivative is
        given, the Lagrangian gradient CasADi evaluates at the solution (``nlp_grad``)
        included, with a structurally zero gradient in the parameters: their multipliers
        are not computed. An evaluation error stays quiet (a Newton solve of an interval
        that does not converge at a trial point is one, on which the solver shortens its
        step; the solve's status says whether it recovered).
        """
        c = condensed(ocp)
        d = ocp.solvers["condensed_derivatives"]
        return SolverNlp({"x": d.x, "p": d.p, "f": d.f, "g": d.g}, d.functions(solver),
                         [bool(e) for e in c.equality()],
                         cache={"nlp_grad": ocp.solvers["condensed_nlp_grad"]},
                         options={"show_eval_warnings": False, "calc_lam_p": False})

    def solve(self, ocp: Any, call: Call, w0: np.ndarray, p: np.ndarray, bounds: tuple,
              lam_x0: np.ndarray | None, lam_g0: np.ndarray | None) -> Any:
        """The start condensed, the solution expanded, the multipliers carried across
        (both in the full layout; their time counts in the solve's)."""
        t0, c0 = time.perf_counter(), time.process_time()
        c = condensed(ocp)
        funcs = ocp.solvers["condensed_derivatives"].functions("ipopt")
        w0_c, p_c = c.condense(w0, p)
        lam_c = (None, None)
        if lam_x0 is not None and lam_g0 is not None:
            lam_c = to_condensed(c, (funcs["grad_f"], funcs["jac_g"]),
                                                       w0_c, p_c, lam_x0, lam_g0)
        cache = ocp.solvers["condensed_cache"]
        points, unsolved = cache.points, cache.unsolved
        cache.begin_call()
        raw = call(w0_c, p_c, c.bounds(bounds), *lam_c)
        unsolved, points = cache.unsolved - unsolved, cache.points - points
        if unsolved and not raw.success:  # the cause of a slow or failed call, said
            raw = dataclasses.replace(raw, status=(
                f"{raw.status} ({unsolved} of the {points} points it evaluated had an "
                "interval whose Newton solve did not converge: evaluation errors, on which "
                "the solver cut its steps back)"))
        raw = _expanded(ocp, c, raw, p_c, p)
        return dataclasses.replace(raw, wall_time_s=time.perf_counter() - t0,
                                   cpu_time_s=time.process_time() - c0)


def _expanded(ocp: Any, c: CondensedNlp, raw: Any, p_c: np.ndarray, p: np.ndarray) -> Any:
    """``raw``, a condensed call's outcome, in the full layout: its point expanded, its
    multipliers carried across. A failed call may end where no multipliers follow from
    stationarity (the NLP's derivatives not finite there, an interval's Newton solve
    diverged): it stays a failed call, its multipliers zero, its status saying why (the
    starts fall back on a failed call; they never warm-start from one)."""
    w = c.expand(raw.w, p_c)
    full = full_derivatives(ocp, "ipopt")
    try:
        lam_x, lam_g = to_full(c, (full["grad_f"], full["jac_g"]), w, p, raw.lam_x, raw.lam_g)
    except FloatingPointError as exc:
        if raw.success:
            raise
        lay = c.full.layout
        return dataclasses.replace(raw, w=w, lam_x=np.zeros(lay.n_w), lam_g=np.zeros(lay.n_g),
                                   status=f"{raw.status} (at its last point {exc})")
    return dataclasses.replace(raw, w=w, lam_x=lam_x, lam_g=lam_g)
