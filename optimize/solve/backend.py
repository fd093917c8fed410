"""NLP solvers of a built OCP: created once per setting, cached on the OCP, and run.

The solver settings come from ``ocp.options.solver``
(:class:`optimize.problem.options.SolverOptions`).
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from optimize.problem.ocp import Bounds, Ocp

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


def derivatives(ocp: Ocp) -> dict[str, ca.Function]:
    """Objective gradient, constraint Jacobian and Lagrangian Hessian (built once).

    Handed to every IPOPT instance, so the warm-start solver costs about a
    second to create instead of repeating the symbolic differentiation.
    """
    if "derivatives" not in ocp.solvers:
        t0 = time.perf_counter()
        x, p, f, g = ocp.nlp["x"], ocp.nlp["p"], ocp.nlp["f"], ocp.nlp["g"]
        lam_f = ca.SX.sym("lam_f")
        lam_g = ca.SX.sym("lam_g", g.shape[0])
        hess = ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])
        ocp.solvers["derivatives"] = {
            "grad_f": ca.Function("nlp_grad_f", [x, p], [f, ca.gradient(f, x)],
                                  ["x", "p"], ["f", "grad_f_x"]),
            "jac_g": ca.Function("nlp_jac_g", [x, p], [g, ca.jacobian(g, x)],
                                 ["x", "p"], ["g", "jac_g_x"]),
            "hess_lag": ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [hess],
                                    ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"]),
        }
        log.debug("NLP derivatives in %.1f s", time.perf_counter() - t0)
    return ocp.solvers["derivatives"]


def solver(ocp: Ocp, warm: bool, bound_push: float | None = None) -> ca.Function:
    """IPOPT solver; ``warm`` selects warm-start options (created once, then cached).

    ``bound_push`` overrides the solver options' ``warm_bound_push`` of a warm solver.
    """
    o = ocp.options.solver
    push = o.warm_bound_push if bound_push is None else bound_push
    key = ("ipopt", warm, push if warm else None)
    if key not in ocp.solvers:
        t0 = time.perf_counter()
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
        ocp.solvers[key] = ca.nlpsol(
            "pumping_cycle", "ipopt", ocp.nlp,
            {"ipopt": ipopt, "print_time": False, "error_on_fail": False, **derivatives(ocp)},
        )
        log.debug("created %s IPOPT solver in %.1f s", "warm" if warm else "cold",
                  time.perf_counter() - t0)
    return ocp.solvers[key]


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
    nlpsol = solver(ocp, warm, bound_push)
    args = {"x0": w0, "p": p, "lbx": bounds[0], "ubx": bounds[1], "lbg": bounds[2],
            "ubg": bounds[3]}
    if warm and lam_x0 is not None and lam_g0 is not None:
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
        status=str(stats["return_status"]),
        success=bool(stats["success"]),
        iterations=int(stats["iter_count"]),
        wall_time_s=wall,
        cpu_time_s=cpu,
    )
