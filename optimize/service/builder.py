"""What one solve needs: the problem (system, drive model, options) and the backend.

A :class:`Problem` is everything a worker needs to build the NLP (all
picklable). The numerical work goes through a *backend*
(:class:`OcpBackend` by default, the CasADi/IPOPT OCP of this package); anything
with the same methods (:class:`Backend`) works, which is how the tests
drive the solve service with a cheap exact solver.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Protocol

from optimize.problem.scenario import Scenario


class SolveResult(Protocol):
    """What the service reads from a solve result (see ``optimize.solve.result.OcpResult``).

    The cycle's figures (``avg_p_mech_w``, ``period_s``, ``trajectory``, ``start``)
    are read where the result has them.
    """

    status: str
    success: bool
    iterations: int
    wall_time_s: float
    avg_p_elec_w: float
    warm: Any


class Backend(Protocol):
    """The numerical side of the service: build once, then solve warm or cold.

    These are every method the service calls. One more is optional:
    ``carry(src, warm, dst, scenario)``, a solution of the NLP ``src`` (of ``scenario``) in
    the layout of another problem's NLP ``dst`` (:meth:`OcpBackend.carry`); a backend
    without it starts a solve from another problem's solution as it is
    (:meth:`optimize.service.foreign.ForeignStart.carried`).
    """

    def build(self, problem: Problem) -> Any:
        """Build (or fetch from the per-process cache) the NLP for ``problem``."""

    def solve(self, ocp: Any, scenario: Scenario, warm: Any,
              period_s: float | None = None) -> SolveResult:
        """Solve ``scenario`` warm-started from ``warm`` (a previous result's ``warm``);
        with ``period_s`` [s], the period held there (only the period scan passes it,
        :mod:`optimize.service.period_scan`)."""

    def cold_start(self, ocp: Any, scenario: Scenario) -> SolveResult:
        """Solve ``scenario`` with no neighbouring solution (stored guess or homotopy)."""

    def remesh(self, coarse: Any, fine: Any, scenario: Scenario,
               result: SolveResult) -> SolveResult:
        """``scenario`` solved on the ``fine`` mesh from ``result``, a converged solve
        on ``coarse``."""

    def period_bounds(self, ocp: Any) -> tuple[float, float]:
        """Bounds [s] of the free period (only the period scan asks)."""

    def check(self, ocp: Any, result: SolveResult, name: str) -> Any:
        """The result check of a converged ``result`` (``passed``: whether the optimum
        stands; ``verdict()``: the summary's text), or None when the backend has nothing
        to check."""

    def from_trajectory(self, ocp: Any, trajectory: Any) -> Any:
        """A converged cycle kept as its trajectory, as a warm start of ``ocp`` (only a
        start from a known cycle asks, :class:`optimize.service.foreign.CycleStart`)."""


@dataclass(frozen=True)
class Problem:
    """Everything a worker needs to build the NLP (all picklable).

    Attributes
    ----------
    model : optimize.model.dae.DaeSpec or None
        How the worker builds the model (factory and plain-data arguments: the DAE
        is built in the worker); ``None`` only for backends that build no model.
    drive_model : Any
        ``fitting.power_model.PowerModel`` (or what the backend takes).
    options : Any
        ``OcpOptions`` (interval count, degree, solver settings).
    key : str
        Cache key of the built NLP: options, system and drive-model hash.
    system : Any
        ``optimize.system.system.System`` the parameters come from (``None`` with
        the package defaults); the built OCP carries it (stored-guess acceptance).
    """

    model: Any
    drive_model: Any
    options: Any
    key: str
    system: Any = None

    @classmethod
    def for_system(cls, system: Any, drive_model: Any, options: Any) -> Problem:
        """The problem of a system (its drive in force, :meth:`System.in_force`) with its
        options (the stored guess switched off, said once here, when its file is damaged:
        :func:`optimize.solve.starts.stored_guess.checked_options`); ``system`` None serves
        stand-in backends only (a real build needs a system)."""
        from optimize.model.dae import DaeSpec
        from optimize.model.kite_model import kite_dae
        from optimize.solve.starts.stored_guess import checked_options

        options = checked_options(options)

        model = DaeSpec(kite_dae) if system is None else system.dae_spec()
        return cls(model, drive_model, options, problem_key(options, drive_model, system),
                   system)

    @property
    def n_intervals(self) -> int:
        """Collocation intervals of its mesh."""
        return self.options.discretization.n_intervals

    def with_intervals(self, n_intervals: int) -> Problem:
        """The same problem on a mesh of ``n_intervals`` (same degree)."""
        if n_intervals == self.n_intervals:
            return self
        options = self.options.replace(discretization={"n_intervals": n_intervals})
        return Problem(self.model, self.drive_model, options,
                       problem_key(options, self.drive_model, self.system), self.system)

    @property
    def scenario_budget_s(self) -> float:
        """How long one scenario's solver runs may take in all [s]:
        :data:`~optimize.problem.deadline.SCENARIO_CALLS` times a call's limit
        (``--call-time-limit``); no limit for the stand-in problems of the tests, which
        have no solver options."""
        from optimize.problem.deadline import SCENARIO_CALLS

        solver = getattr(self.options, "solver", None)
        return math.inf if solver is None else SCENARIO_CALLS * solver.call_time_limit_s

    def refined(self) -> Problem | None:
        """The same problem on twice the collocation intervals (the mesh check's and the
        last retry's mesh); None when that exceeds
        :data:`optimize.problem.options.MAX_INTERVALS`."""
        from optimize.problem.options import MAX_INTERVALS

        n = 2 * self.n_intervals
        return self.with_intervals(n) if n <= MAX_INTERVALS else None


def problem_key(options: Any, drive_model: Any, system: Any) -> str:
    """NLP cache key: options, drive-model hash, system hash and the drive in force."""
    if system is None:
        return f"{options!r}|{drive_model.sha256}|defaults"
    return f"{options!r}|{drive_model.sha256}|{system.sha256}|{system.drive_key()}"


#: per-process NLP cache: (Problem.key, thread id) -> built OCP. Per thread, because
#: a CasADi solver object must not be used by two threads at once.
_OCP_CACHE: dict[tuple[str, int], Any] = {}


class OcpBackend:
    """The CasADi/IPOPT OCP of this package (:mod:`optimize.problem.ocp`, solved by
    :mod:`optimize.solve.solve`)."""

    def build(self, problem: Problem) -> Any:
        """Build the NLP once per process and per :attr:`Problem.key`."""
        from optimize.problem.ocp import build_ocp

        key = (problem.key, threading.get_ident())
        if key not in _OCP_CACHE:
            _OCP_CACHE[key] = build_ocp(problem.model.build(), problem.drive_model,
                                        problem.options, system=problem.system)
        return _OCP_CACHE[key]

    def solve(self, ocp: Any, scenario: Scenario, warm: Any,
              period_s: float | None = None) -> SolveResult:
        """Warm-started solve (primal and dual start; on failure ``solve`` retries the same
        primal point once with cold barrier settings, before the service's own fallbacks),
        with the period held at ``period_s`` [s] when given."""
        from optimize.solve.solve import solve

        return solve(ocp, scenario, warm, period_s=period_s)

    def cold_start(self, ocp: Any, scenario: Scenario) -> SolveResult:
        """From the stored initial guess when it fits, else the homotopy."""
        from optimize.solve.starts.cold import start

        return start(ocp, scenario)

    def carry(self, src: Any, warm: Any, dst: Any, scenario: Scenario) -> Any:
        """``warm``, a solution of the NLP ``src`` (of ``scenario``), in the layout of
        another problem's NLP ``dst`` (:func:`optimize.solve.result.carry_over`)."""
        from optimize.solve.result import carry_over

        return carry_over(src, warm, dst, scenario.parameters)

    def from_trajectory(self, ocp: Any, trajectory: Any) -> Any:
        """A converged cycle of ``ocp`` kept as its trajectory, as its start
        (:func:`optimize.solve.starts.cycle.solution_of_trajectory`)."""
        from optimize.solve.starts.cycle import solution_of_trajectory

        return solution_of_trajectory(ocp, trajectory)

    def remesh(self, coarse: Any, fine: Any, scenario: Scenario,
               result: SolveResult) -> SolveResult:
        """From ``result`` interpolated onto the finer mesh
        (:func:`optimize.solve.starts.remesh.solve_interpolated`)."""
        from optimize.solve.starts.remesh import solve_interpolated

        return solve_interpolated(coarse, fine, scenario, result)

    def period_bounds(self, ocp: Any) -> tuple[float, float]:
        """Bounds [s] of the free period of ``ocp`` (the system's)."""
        return ocp.formulation.period_bounds()

    def check(self, ocp: Any, result: SolveResult, name: str) -> Any:
        """The physical check of every converged optimum
        (:func:`optimize.analysis.result_check.check_result`)."""
        from optimize.analysis.result_check import check_result

        return check_result(ocp, result, name)
