"""NLP solvers of a built OCP: created once per setting, cached on the OCP, and run.

The solver and its settings come from ``ocp.options.solver``
(:class:`optimize.problem.options.SolverOptions`): IPOPT on the general sparse
layout, with the linear solver of ``linear_solver`` (MUMPS by default; the HSL
solvers and Pardiso are loaded by IPOPT from the user's library at run time), or
fatrop on the stage-wise layout (:func:`optimize.problem.transcription.stagewise_collocation`).
With ``transcription = "condensed"`` either solver runs on the condensed NLP
(:mod:`optimize.problem.condensed`), built once beside the OCP's full one; starts and
solutions cross over in the full layout (:mod:`optimize.solve.condensed_solve`).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca
import numpy as np

from optimize.problem.condensed import CondensedNlp, condensed_nlp
from optimize.problem.ocp import Bounds, Ocp
from optimize.solve import codegen, condensed_solve
from optimize.solve.condensed_derivatives import condensed_derivatives
from optimize.solve.derivatives import nlp_derivatives

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RawSolve:
    """Outcome of one solver call: scaled primal/dual vectors and solver statistics."""

    w: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    objective: float
    status: str
    success: bool
    iterations: int
    wall_time_s: float
    cpu_time_s: float  # CPU time of this process during the call [s]


def _single_threaded_blas() -> None:
    """Let casadi's bundled OpenBLAS (MUMPS' BLAS) run one thread, unless the user chose.

    OpenBLAS reads ``OPENBLAS_NUM_THREADS`` when it loads, which casadi does on the
    first IPOPT solver with MUMPS. On this NLP (about 6,100 variables) a second BLAS
    thread only spins, and the sweep already runs one solver per core (measured with
    ``benchmarks/optimize_sweep_benchmark.py``, figures in benchmarks/README.md).
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _compile_fn(ocp: Ocp) -> Callable[[ca.Function], ca.Function] | None:
    """How the OCP's repeated functions are compiled: :func:`optimize.solve.codegen.compiled`
    when ``options.solver.codegen`` is set, else not at all (None)."""
    return codegen.compiled if ocp.options.solver.codegen else None


def derivatives(ocp: Ocp) -> dict[str, ca.Function]:
    """Objective gradient, constraint Jacobian and Lagrangian Hessian (built once).

    Handed to every IPOPT instance, so the warm-start solver costs about a
    second to create instead of repeating the differentiation
    (:func:`optimize.solve.derivatives.nlp_derivatives`).
    """
    if "derivatives" not in ocp.solvers:
        ocp.solvers["derivatives"] = nlp_derivatives(ocp.transcription,
                                                     compile_fn=_compile_fn(ocp))
    return ocp.solvers["derivatives"]


#: linear solvers IPOPT accepts; all but MUMPS and SPRAL are loaded at run time
IPOPT_LINEAR_SOLVERS = ("mumps", "spral", "ma27", "ma57", "ma77", "ma86", "ma97", "pardiso")
#: the library IPOPT loads for them (found through the library path, LD_LIBRARY_PATH)
RUNTIME_LIBRARIES = {**{f"ma{n}": "libhsl.so" for n in (27, 57, 77, 86, 97)},
                     "pardiso": "libpardiso.so"}


def check_linear_solver(name: str) -> None:
    """Refuse an IPOPT linear solver that is unknown or whose library does not load.

    Solves a two-variable NLP with it (milliseconds), so a missing HSL library is
    said before any OCP is built.

    Raises
    ------
    ValueError
        Naming the solver, the library IPOPT looked for and how to provide it.
    """
    if name not in IPOPT_LINEAR_SOLVERS:
        raise ValueError(f"unknown IPOPT linear solver {name!r}; one of "
                         + ", ".join(IPOPT_LINEAR_SOLVERS))
    x = ca.SX.sym("x", 2)
    probe = ca.nlpsol("linear_solver_probe", "ipopt",
                      {"x": x, "f": ca.sumsqr(x - 1), "g": x[0] + x[1]},
                      {"ipopt": {"linear_solver": name, "print_level": 0, "sb": "yes"},
                       "print_time": False, "error_on_fail": False})
    _single_threaded_blas()
    probe(x0=[0.0, 0.0], lbg=0.0, ubg=1.0)
    status = str(probe.stats()["return_status"])
    if not probe.stats()["success"]:
        lib = RUNTIME_LIBRARIES.get(name, "its library")
        raise ValueError(
            f"IPOPT cannot use the linear solver {name!r} here ({status}): it loads {lib} at "
            f"run time and did not find it. Install the library (HSL: the coinhsl package "
            f"from licences.stfc.ac.uk) and put its folder on LD_LIBRARY_PATH, or use "
            f"--linear-solver mumps (the default)")


def solver(ocp: Ocp, warm: bool, bound_push: float | None = None) -> ca.Function:
    """The OCP's NLP solver; ``warm`` selects warm-start options (created once, then
    cached on the OCP).

    ``bound_push`` overrides the solver options' ``warm_bound_push`` of a warm solver.
    """
    o = ocp.options.solver
    push = o.warm_bound_push if bound_push is None else bound_push
    key = (o.solver, o.transcription, warm, push if warm else None)
    if key not in ocp.solvers:
        t0 = time.perf_counter()
        make = _fatrop if o.solver == "fatrop" else _ipopt
        ocp.solvers[key] = make(ocp, warm, push)
        log.debug("created %s %s solver (%s) in %.1f s", "warm" if warm else "cold", o.solver,
                  o.transcription, time.perf_counter() - t0)
    return ocp.solvers[key]


def condensed(ocp: Ocp) -> CondensedNlp:
    """The OCP's condensed NLP (built once, cached on the OCP)."""
    if "condensed" not in ocp.solvers:
        t0 = time.perf_counter()
        compile_fn = _compile_fn(ocp)
        # CasADi generates C code for its dense Newton method, not for the sparse one
        rootfinder = "fast_newton" if compile_fn and codegen.compiler() else "newton"
        c = condensed_nlp(ocp.formulation, ocp.coll, ocp.transcription, rootfinder)
        derivs, callbacks = condensed_derivatives(c, compile_fn)
        ocp.solvers["condensed"] = c
        ocp.solvers["condensed_derivatives"] = derivs
        # the callbacks into the interval cache live as long as the solvers that call them
        ocp.solvers["condensed_callbacks"] = callbacks
        log.info("built the condensed NLP (%s%s): %d variables, %d constraints in %.1f s",
                 rootfinder, ", compiled" if compile_fn else "", c.n_w, c.n_g,
                 time.perf_counter() - t0)
    return ocp.solvers["condensed"]


def _condensed_nlp(ocp: Ocp, solver: str) -> tuple[dict, dict]:
    """The condensed NLP as ``solver`` runs it and the options that hand it its functions.

    Its objective and rows come from the intervals solved once per point
    (:class:`optimize.solve.condensed_derivatives.IntervalCache`), reached through
    callbacks CasADi cannot differentiate. So every derivative is given, the Lagrangian
    gradient CasADi evaluates at the solution (``nlp_grad``) included, with a structurally
    zero gradient in the parameters: their multipliers are not computed. An evaluation
    error stays quiet (a Newton solve of an interval that does not converge at a trial
    point is one, on which the solver shortens its step; the solve's status says whether
    it recovered).
    """
    condensed(ocp)
    d = ocp.solvers["condensed_derivatives"]
    grad_x = d.lam_f * d.grad + ca.mtimes(d.jac.T, d.lam_g)
    nlp_grad = ca.Function("nlp_grad", [d.x, d.p, d.lam_f, d.lam_g],
                           [d.f, d.g, grad_x, ca.MX(d.p.shape[0], 1)],
                           ["x", "p", "lam_f", "lam_g"],
                           ["f", "g", "grad_gamma_x", "grad_gamma_p"])
    fns = d.functions(solver)
    opts = {"show_eval_warnings": False, "calc_lam_p": False}
    if solver == "ipopt":
        opts.update(fns, cache={"nlp_grad": nlp_grad})
    else:
        opts["cache"] = {**fns, "nlp_grad": nlp_grad}
    return {"x": d.x, "p": d.p, "f": d.f, "g": d.g}, opts


def _ipopt(ocp: Ocp, warm: bool, push: float) -> ca.Function:
    """IPOPT with the OCP's linear solver on the general layout (or the condensed NLP)."""
    o = ocp.options.solver
    ipopt = {
        "linear_solver": o.linear_solver,
        "mumps_pivot_order": o.mumps_pivot_order,
        "tol": o.tol,
        "acceptable_tol": o.acceptable_tol,
        "acceptable_iter": 5,
        "max_iter": o.max_iter,
        "print_level": 0,
        "sb": "yes",
        # the NLP is scaled by construction; MUMPS' own scaling cost time and
        # iterations in the measurements of benchmarks/optimize_solve.py
        "mumps_scaling": 0,
        "mumps_permuting_scaling": 0,
    }
    if warm:
        ipopt.update(
            {
                "warm_start_init_point": "yes",
                "mu_init": o.warm_mu_init,
                "warm_start_bound_push": push,
                "warm_start_bound_frac": push,
                "warm_start_slack_bound_push": push,
                "warm_start_slack_bound_frac": push,
                "warm_start_mult_bound_push": push,
            }
        )
    _single_threaded_blas()
    nlp, given = ((ocp.nlp, derivatives(ocp)) if o.transcription == "collocation"
                  else _condensed_nlp(ocp, "ipopt"))
    return ca.nlpsol("pumping_cycle", "ipopt", nlp,
                     {"ipopt": ipopt, "print_time": False, "error_on_fail": False, **given})


def _fatrop_derivatives(ocp: Ocp) -> dict[str, ca.Function]:
    """Objective gradient, constraint Jacobian and Lagrangian gradient and (full, symmetric)
    Hessian in the form the fatrop interface evaluates (built once per OCP)."""
    if "fatrop_derivatives" not in ocp.solvers:
        ocp.solvers["fatrop_derivatives"] = nlp_derivatives(ocp.transcription, "fatrop",
                                                            _compile_fn(ocp))
    return ocp.solvers["fatrop_derivatives"]


def _fatrop(ocp: Ocp, warm: bool, push: float) -> ca.Function:
    """fatrop on the stage-wise layout, structure detected from the Jacobian."""
    o = ocp.options.solver
    opts = {"tol": o.tol, "tol_acceptable": o.acceptable_tol, "acceptable_iter": 5,
            "max_iter": o.max_iter, "print_level": 0}
    if warm:  # fatrop takes no multipliers: a warm start is the primal point, a small barrier
        opts.update({"mu_init": o.warm_mu_init, "bound_push": push, "bound_frac": push})
    if o.transcription == "condensed":
        nlp, given = _condensed_nlp(ocp, "fatrop")
        return ca.nlpsol("pumping_cycle", "fatrop", nlp, {
            "structure_detection": "auto",
            "equality": [bool(e) for e in condensed(ocp).equality()],
            "fatrop": opts, "print_time": False, "error_on_fail": False, **given})
    return ca.nlpsol("pumping_cycle", "fatrop", ocp.nlp, {
        "structure_detection": "auto",
        "equality": [bool(e) for e in ocp.layout.equality],
        "fatrop": opts, "print_time": False, "error_on_fail": False,
        "cache": _fatrop_derivatives(ocp)})


#: casadi's unified return status of fatrop, in words
FATROP_STATUS = {"SOLVER_RET_SUCCESS": "converged", "SOLVER_RET_LIMITED": "iteration limit",
                 "SOLVER_RET_UNKNOWN": "failed", "SOLVER_RET_EXCEPTION": "exception",
                 "SOLVER_RET_NAN": "NaN in a function evaluation"}


def solver_status(stats: dict) -> str:
    """The solver's own return status: IPOPT's name, or fatrop's return flag and its meaning."""
    if "fatrop" in stats:
        unified = str(stats.get("unified_return_status", ""))
        return (f"fatrop return flag {stats['fatrop'].get('return_flag')}: "
                f"{FATROP_STATUS.get(unified, unified)}")
    return str(stats["return_status"])


def run(
    ocp: Ocp,
    w0: np.ndarray,
    p: np.ndarray,
    bounds: Bounds,
    warm: bool,
    lam_x0: np.ndarray | None = None,
    lam_g0: np.ndarray | None = None,
    bound_push: float | None = None,
) -> RawSolve:
    """One solve from the scaled primal ``w0`` (and multipliers when ``warm``).

    ``bound_push`` overrides the solver options' ``warm_bound_push`` of a warm solve.
    """
    if ocp.options.solver.transcription == "condensed":
        return _run_condensed(ocp, w0, p, bounds, warm, lam_x0, lam_g0, bound_push)
    return _call(solver(ocp, warm, bound_push), w0, p, bounds, lam_x0 if warm else None,
                 lam_g0 if warm else None)


def _call(nlpsol: ca.Function, w0: np.ndarray, p: np.ndarray, bounds: Bounds,
          lam_x0: np.ndarray | None, lam_g0: np.ndarray | None) -> RawSolve:
    """One call of ``nlpsol``, with the multipliers when both are given."""
    args = {"x0": w0, "p": p, "lbx": bounds[0], "ubx": bounds[1], "lbg": bounds[2],
            "ubg": bounds[3]}
    if lam_x0 is not None and lam_g0 is not None:
        args.update(lam_x0=lam_x0, lam_g0=lam_g0)
    t0, c0 = time.perf_counter(), time.process_time()
    sol = nlpsol(**args)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    stats = nlpsol.stats()
    return RawSolve(
        w=np.asarray(sol["x"]).ravel(),
        lam_x=np.asarray(sol["lam_x"]).ravel(),
        lam_g=np.asarray(sol["lam_g"]).ravel(),
        objective=float(sol["f"]),
        status=solver_status(stats),
        success=bool(stats["success"]),
        iterations=int(stats["iter_count"]),
        wall_time_s=wall,
        cpu_time_s=cpu,
    )


def _run_condensed(ocp: Ocp, w0: np.ndarray, p: np.ndarray, bounds: Bounds, warm: bool,
                   lam_x0: np.ndarray | None, lam_g0: np.ndarray | None,
                   bound_push: float | None) -> RawSolve:
    """:func:`run` on the condensed NLP: the start condensed, the solution expanded, the
    multipliers carried across (both in the full layout; their time counts in the
    solve's)."""
    t0, c0 = time.perf_counter(), time.process_time()
    c = condensed(ocp)
    funcs = ocp.solvers["condensed_derivatives"].functions("ipopt")
    first_order = (funcs["grad_f"], funcs["jac_g"])
    w0_c, p_c = c.condense(w0, p)
    lam_c = (None, None)
    if warm and lam_x0 is not None and lam_g0 is not None:
        lam_c = condensed_solve.to_condensed(c, first_order, w0_c, p_c, lam_x0, lam_g0)
    raw = _call(solver(ocp, warm, bound_push), w0_c, p_c, c.bounds(bounds), *lam_c)
    w = c.expand(raw.w, p_c)
    full = derivatives(ocp)
    lam_x, lam_g = condensed_solve.to_full(c, (full["grad_f"], full["jac_g"]), w, p,
                                           raw.lam_x, raw.lam_g)
    return dataclasses.replace(raw, w=w, lam_x=lam_x, lam_g=lam_g,
                               wall_time_s=time.perf_counter() - t0,
                               cpu_time_s=time.process_time() - c0)
