"""NLP solvers of a built OCP: created once per setting, cached on the OCP, and run.

The solver and its settings come from ``ocp.options.solver``
(:class:`optimize.problem.options.SolverOptions`): IPOPT, with the linear solver of
``linear_solver`` (MUMPS by default; the HSL solvers and Pardiso are loaded by IPOPT
from the user's library at run time), or fatrop. What it runs on, with which
derivatives, and how a start and a solution cross to it, is the transcription method's
(:func:`optimize.problem.transcriptions.method_of`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.deadline import (
    COLD_START_CALLS,
    WALL_STATUS,
    deadline,
    hard_stop,
    passed,
)
from optimize.problem.ocp import Bounds, Ocp
from optimize.problem.transcriptions import method_of

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

    def stage(self, name: str, extra_wall_s: float = 0.0) -> dict:
        """The record of this call as one of a solve's ``stages`` (``name``: what it was,
        e.g. ``"warm"``; ``extra_wall_s`` [s]: time spent on its start, added to its wall
        time)."""
        return {"stage": name, "status": self.status, "success": self.success,
                "iterations": self.iterations, "wall_time_s": self.wall_time_s + extra_wall_s,
                "cpu_time_s": self.cpu_time_s}


def _single_threaded_blas() -> None:
    """Let casadi's bundled OpenBLAS (MUMPS' BLAS) run one thread, unless the user chose.

    OpenBLAS reads ``OPENBLAS_NUM_THREADS`` when it loads, which casadi does on the
    first IPOPT solver with MUMPS. On this NLP (about 6,100 variables) a second BLAS
    thread only spins, and the sweep already runs one solver per core (measured with
    ``benchmarks/optimize_sweep_benchmark.py``, figures in benchmarks/README.md).
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


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


@dataclass(frozen=True)
class Setting:
    """How one solve runs beyond the solver options: its barrier parameter and its
    iteration cap (fatrop: only ``mu_init`` of a warm solve and ``max_iter``).

    Attributes
    ----------
    mu_init : float or None
        Initial barrier parameter; None: IPOPT's default for a cold solve, the solver
        options' ``warm_mu_init`` for a warm one.
    mu_target : float
        0 (a solve to the options' tolerance), or the barrier parameter a homotopy's
        intermediate stage ends at: it stops on the central path there, to a tolerance of
        ``mu_target`` (acceptable at ten times it), and the next stage warm-starts at
        the same barrier instead of climbing back from an optimum at zero.
    max_iter : int or None
        Iteration cap; None: the solver options' ``max_iter``. 0 only checks the start:
        it succeeds when the start already is an optimum to the tolerance.
    """

    mu_init: float | None = None
    mu_target: float = 0.0
    max_iter: int | None = None


#: the default: IPOPT's own cold barrier, the options' warm one, a solve to the tolerance
FULL = Setting()


def solver(ocp: Ocp, warm: bool, bound_push: float | None = None,
           setting: Setting = FULL) -> ca.Function:
    """The OCP's NLP solver; ``warm`` selects warm-start options (created once, then
    cached on the OCP).

    ``bound_push`` overrides the solver options' ``warm_bound_push`` of a warm solver;
    ``setting`` sets its barrier parameter and iteration cap (:class:`Setting`).
    """
    o = ocp.options.solver
    push = o.warm_bound_push if bound_push is None else bound_push
    key = _key(ocp, warm, bound_push, setting)
    if key not in ocp.solvers:
        t0 = time.perf_counter()
        ocp.solvers[key] = MAKERS[o.solver](ocp, warm, push, setting)
        log.debug("created %s %s solver (%s) in %.1f s", "warm" if warm else "cold", o.solver,
                  o.transcription, time.perf_counter() - t0)
    return ocp.solvers[key]


def _key(ocp: Ocp, warm: bool, bound_push: float | None, setting: Setting) -> tuple:
    """The key of :func:`solver`'s solver in ``ocp.solvers``."""
    o = ocp.options.solver
    push = o.warm_bound_push if bound_push is None else bound_push
    return (o.solver, o.transcription, warm, push if warm else None, setting)


def _ipopt(ocp: Ocp, warm: bool, push: float, setting: Setting) -> ca.Function:
    """IPOPT with the OCP's linear solver on the general layout (or the condensed NLP)."""
    o = ocp.options.solver
    ipopt = {
        "linear_solver": o.linear_solver,
        "mumps_pivot_order": o.mumps_pivot_order,
        "tol": o.tol,
        "acceptable_tol": o.acceptable_tol,
        "acceptable_iter": 5,
        "max_iter": o.max_iter if setting.max_iter is None else setting.max_iter,
        "max_wall_time": o.call_time_limit_s,
        "print_level": 0,
        "sb": "yes",
        # the NLP is scaled by construction; MUMPS' own scaling cost time and
        # iterations in the measurements of benchmarks/optimize_solve.py
        "mumps_scaling": 0,
        "mumps_permuting_scaling": 0,
    }
    if setting.mu_target > 0:
        ipopt.update({"mu_target": setting.mu_target, "tol": setting.mu_target,
                      "acceptable_tol": 10 * setting.mu_target})
    if setting.mu_init is not None:
        ipopt["mu_init"] = setting.mu_init
    if warm:
        ipopt.update(
            {
                "warm_start_init_point": "yes",
                "mu_init": o.warm_mu_init if setting.mu_init is None else setting.mu_init,
                "warm_start_bound_push": push,
                "warm_start_bound_frac": push,
                "warm_start_slack_bound_push": push,
                "warm_start_slack_bound_frac": push,
                "warm_start_mult_bound_push": push,
            }
        )
    _single_threaded_blas()
    sn = method_of(o).solver_nlp(ocp, "ipopt")
    extra = {"cache": sn.cache} if sn.cache else {}
    return ca.nlpsol("pumping_cycle", "ipopt", sn.nlp, {
        "ipopt": ipopt, "print_time": False, "error_on_fail": False, **sn.options,
        **sn.functions, **extra})


def _fatrop(ocp: Ocp, warm: bool, push: float, setting: Setting) -> ca.Function:
    """fatrop on the transcription's stages, structure detected from the Jacobian."""
    o = ocp.options.solver
    opts = {"tol": o.tol, "tol_acceptable": o.acceptable_tol, "acceptable_iter": 5,
            "max_iter": o.max_iter if setting.max_iter is None else setting.max_iter,
            "print_level": 0}
    if warm:  # fatrop takes no multipliers: a warm start is the primal point, a small barrier
        mu = o.warm_mu_init if setting.mu_init is None else setting.mu_init
        opts.update({"mu_init": mu, "bound_push": push, "bound_frac": push})
    sn = method_of(o).solver_nlp(ocp, "fatrop")
    return ca.nlpsol("pumping_cycle", "fatrop", sn.nlp, {
        "structure_detection": "auto", "equality": sn.equality, "fatrop": opts,
        "print_time": False, "error_on_fail": False, **sn.options,
        "cache": {**sn.functions, **sn.cache}})


#: the solver of each name (:data:`optimize.problem.options.SOLVERS`)
MAKERS = {"ipopt": _ipopt, "fatrop": _fatrop}


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
    setting: Setting = FULL,
) -> RawSolve:
    """One solve from the scaled primal ``w0`` (and multipliers when ``warm``).

    ``bound_push`` overrides the solver options' ``warm_bound_push`` of a warm solve;
    ``setting`` sets the barrier parameter and the iteration cap (:class:`Setting`).

    The call runs at most ``ocp.options.solver.call_time_limit_s`` seconds,
    and none is made past this thread's deadline (:mod:`optimize.problem.deadline`): a
    call stopped so, or not made, fails with the status
    :data:`~optimize.problem.deadline.WALL_STATUS` and what the solver said. A call that
    does not return ends its worker process at its hard stop
    (:func:`~optimize.problem.deadline.hard_stop`).
    """
    limit_s = ocp.options.solver.call_time_limit_s
    if passed():
        return _unsolved(ocp, w0, f"{WALL_STATUS}: not run, the solve's "
                         f"{COLD_START_CALLS * limit_s:g} s were spent", 0.0)
    nlpsol = solver(ocp, warm, bound_push, setting)

    def call(w: np.ndarray, p_: np.ndarray, b: Bounds, lam_x: np.ndarray | None,
             lam_g: np.ndarray | None) -> RawSolve:
        return _call(nlpsol, w, p_, b, lam_x, lam_g)

    t0 = time.perf_counter()
    with deadline(limit_s), hard_stop(limit_s):
        try:
            raw = method_of(ocp.options.solver).solve(ocp, call, w0, p, bounds,
                                                      lam_x0 if warm else None,
                                                      lam_g0 if warm else None)
        except RuntimeError as exc:  # fatrop's call, ended by a refused evaluation
            if not passed():
                raise
            raw = _unsolved(ocp, w0, f"{type(exc).__name__} at the deadline",
                            time.perf_counter() - t0)
        late = passed()
    if not raw.success and ocp.options.solver.solver == "fatrop":
        # a fatrop solver keeps a failed call's state: on the condensed NLP the next call
        # through it failed at once (return flag 5, 0 iterations) where a new one converged
        ocp.solvers.pop(_key(ocp, warm, bound_push, setting), None)
    if raw.success or not (late or raw.status.startswith("Maximum_WallTime_Exceeded")):
        return raw
    return dataclasses.replace(raw, status=(
        f"{WALL_STATUS}: stopped after {raw.wall_time_s:.0f} s (at most {limit_s:g} s a "
        f"call, {COLD_START_CALLS * limit_s:g} s a solve: --call-time-limit), "
        f"{raw.iterations} iterations; the solver said {raw.status}"))


def _unsolved(ocp: Ocp, w0: np.ndarray, status: str, wall_time_s: float) -> RawSolve:
    """A call that gave no iterate: the start, no multipliers, ``status``."""
    return RawSolve(np.asarray(w0, dtype=float), np.zeros(len(w0)), np.zeros(ocp.layout.n_g),
                    math.nan, status, False, 0, wall_time_s, 0.0)


#: CasADi's warnings a call's own status already says, kept off the user's screen: after a
#: failed fatrop call CasADi evaluates the NLP once more at the call's last point to compute
#: its multipliers, and where an interval's Newton solve does not converge there (the
#: condensed NLP) it warns, once per such call, beside the status that says the call failed
QUIET_WARNINGS = ("Failed to calculate multipliers",)


class _Dropping:
    """A text stream that passes on to ``stream`` the lines written to it, but those that
    hold one of ``texts``: whole lines, as CasADi writes a warning in pieces (its prefix,
    its text, its source); :meth:`flush_rest` passes on an unfinished last line."""

    def __init__(self, stream: Any, texts: tuple[str, ...]) -> None:
        self._stream, self._texts, self._line = stream, texts, ""

    def write(self, text: str) -> int:
        *lines, self._line = (self._line + text).split("\n")
        kept = "".join(f"{line}\n" for line in lines
                       if not any(t in line for t in self._texts))
        if kept:
            self._stream.write(kept)
        return len(text)

    def flush_rest(self) -> None:
        if self._line and not any(t in self._line for t in self._texts):
            self._stream.write(self._line)
        self._line = ""

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


@contextmanager
def _quiet_stderr(texts: tuple[str, ...]) -> Iterator[None]:
    """While open, the lines written to ``sys.stderr`` that hold one of ``texts`` are
    dropped (CasADi writes its warnings there, through the interpreter)."""
    before = sys.stderr
    sys.stderr = dropping = _Dropping(before, texts)
    try:
        yield
    finally:
        sys.stderr = before
        dropping.flush_rest()


def _call(nlpsol: ca.Function, w0: np.ndarray, p: np.ndarray, bounds: Bounds,
          lam_x0: np.ndarray | None, lam_g0: np.ndarray | None) -> RawSolve:
    """One call of ``nlpsol``, with the multipliers when both are given."""
    args = {"x0": w0, "p": p, "lbx": bounds[0], "ubx": bounds[1], "lbg": bounds[2],
            "ubg": bounds[3]}
    if lam_x0 is not None and lam_g0 is not None:
        args.update(lam_x0=lam_x0, lam_g0=lam_g0)
    t0, c0 = time.perf_counter(), time.process_time()
    with _quiet_stderr(QUIET_WARNINGS):
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
