"""Options of the cycle OCP in two groups: discretization and solver.

* :class:`Discretization`: how the cycle is transcribed (intervals, collocation
  degree, the control regularization that keeps the discretized controls smooth).
* :class:`SolverOptions`: which NLP solver runs and how (tolerances, warm starts,
  linear solver, the stored initial guess).

:class:`OcpOptions` holds one of each; ``OcpOptions()`` is the default::

    options = OcpOptions(Discretization(n_intervals=20), solver=SolverOptions(tol=1e-8))
    options.discretization.n_intervals, options.solver.tol

The physical bounds are not options: the OCP's parts read them from the system's
sections (:mod:`optimize.system.sections`, the drive's from the ``[drive]`` in force).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from optimize.problem.deadline import CALL_WALL_LIMIT_S

#: the reel speed's and the body rates' bounds when the system states none: the solver's
#: range [m/s], [rad/s] (three turns a second)
SOLVER_REEL_SPEED_M_S, SOLVER_BODY_RATE_RAD_S = 100.0, 6 * math.pi

#: most collocation intervals per period: the default is 40 and the trust check's mesh
#: refinement doubles it; 400 already means ~10^5 NLP variables and minutes per solve
MAX_INTERVALS = 400
#: documented minimum mesh: collocation points per cycle (intervals x degree); coarser
#: optima the result check flags (:mod:`optimize.analysis.result_check`)
MIN_COLLOCATION_POINTS = 40


@dataclass(frozen=True)
class Discretization:
    """How the periodic cycle is transcribed into an NLP.

    Parameters
    ----------
    n_intervals : int
        Number of collocation intervals over one period.
    degree : int
        Radau collocation degree.
    regularization_w : float
        Weight of the control regularization ``mean_k sum_i (u_i / sigma_i)^2``
        [W]. The default 0.1 W is the weight of the reference
        implementation (rawesome ``pumping_poweropt.py``: 0.1 (u/sigma)^2 in W).
    control_sigma : (float, float, float, float)
        Scales ``sigma`` of tether jerk [m/s^3] and aileron, elevator, rudder
        rates [rad/s]. Default (10, 1, 1, 1). The reference implementation
        used (10, 0.001, 0.8, 0.1), which practically freezes the aileron; at
        N = 40 and 7 m/s that reproduces the reference prototype's table to the watt
        (-1528 W / -48 W / 3.36 s mechanical) but leaves the 10 m/s periods
        further from the paper's (2.39 s and 4.2 s against 2.14 s and 3.89 s;
        the default gives 2.22 s and 3.82 s).
    """

    n_intervals: int = 40
    degree: int = 4
    regularization_w: float = 0.1
    control_sigma: tuple[float, float, float, float] = (10.0, 1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        if not 2 <= self.n_intervals <= MAX_INTERVALS:
            raise ValueError(f"n_intervals must be 2 to {MAX_INTERVALS}, got {self.n_intervals}")
        if not 1 <= self.degree <= 9:
            raise ValueError(f"degree must be 1 to 9, got {self.degree}")
        if len(self.control_sigma) != 4 or min(self.control_sigma) <= 0:
            raise ValueError(f"control_sigma must be 4 positive scales, got {self.control_sigma}")


#: NLP solvers the OCP can be handed to
SOLVERS = ("ipopt", "fatrop")
#: the solvers that take the collocation's stage-wise layout (Riccati-based)
STAGEWISE_SOLVERS = ("fatrop",)
#: transcriptions the solver runs on (:mod:`optimize.problem.transcriptions`,
#: :mod:`optimize.problem.transcriptions.condensed_nlp`)
TRANSCRIPTIONS = ("collocation", "condensed")


@dataclass(frozen=True)
class SolverOptions:
    """Which NLP solver runs and with which settings.

    Parameters
    ----------
    solver : str
        NLP solver (one of :data:`SOLVERS`): ``"ipopt"`` (the default: IPOPT on the
        general sparse layout) or ``"fatrop"`` (a Riccati-based interior-point solver
        shipped with CasADi, on the stage-wise layout of the same NLP; it takes no dual
        warm start, and on this OCP it is slower per iteration and less robust than
        IPOPT with MUMPS, see ``benchmarks/solver_comparison.py``).
    tol : float
        Convergence tolerance (scaled problem).
    acceptable_tol : float
        IPOPT acceptable tolerance.
    max_iter : int
        Iteration limit per solve.
    warm_mu_init : float
        Initial barrier parameter of a warm-started solve.
    warm_bound_push : float
        IPOPT's ``warm_start_bound_push``, ``_bound_frac``, ``_slack_bound_push``,
        ``_slack_bound_frac`` and ``_mult_bound_push`` of a warm-started solve:
        how far (scaled units) the warm point and its bound multipliers are moved
        off their bounds. A neighbouring optimum has other active bounds; left
        within 1e-9 of them, the fraction-to-the-boundary rule cut the first
        steps to 1e-7..1e-2 of their length.
    stored_guess : bool
        Start a scenario with no neighbouring solution from the shipped initial
        guess (:mod:`optimize.solve.starts.stored_guess`) when it fits, instead of the homotopy.
    start_file : str or None
        A start file of the stored guess's format to use instead of the shipped one
        (a sweep's ``start.npz``); None: the shipped file.
    linear_solver : str
        IPOPT linear solver: ``"mumps"`` (default), ``"spral"``, or one IPOPT loads
        at run time from the user's library (HSL ``"ma27"``, ``"ma57"``, ``"ma77"``,
        ``"ma86"``, ``"ma97"`` from ``libhsl.so``; ``"pardiso"``); checked by
        :func:`optimize.solve.nlp_solver.check_linear_solver`.
    mumps_pivot_order : int
        MUMPS fill-reducing ordering (0 AMD, 2 AMF, 4 PORD, 6 QAMD, 7 automatic).
        AMD makes an iteration on this NLP cheaper than the automatic choice
        (measured by ``benchmarks/optimize_solve.py``, figures in benchmarks/README.md).
    transcription : str
        What the solver runs on (one of :data:`TRANSCRIPTIONS`): ``"collocation"`` (the
        default: every Radau point's states and algebraic variables are NLP variables)
        or ``"condensed"`` (multiple shooting, each interval's collocation solved inside
        the interval, :mod:`optimize.problem.transcriptions.condensed_nlp`). Both have the
        same optima; results and warm starts are in the collocation layout either way.
    codegen : bool
        Compile the NLP's repeated functions to C where a C compiler is found
        (:mod:`optimize.problem.transcriptions.codegen`, cached by hash, so only the first
        use of a model compiles): the Radau point's Jacobian and Hessian for ``"collocation"``, each
        interval's solve and derivatives for ``"condensed"``. Off by default: it needs a
        C compiler, and on the paper sweep it saved 17 % of the CPU after 3 s of gcc
        (collocation) and 16 % after 34 s (condensed) (benchmarks/README.md); False runs
        them in CasADi's virtual machine.
    predictor_step : float
        Fraction of the tangential predictor's step (:mod:`optimize.solve.starts.predictor`)
        a warm start from another wind speed or objective takes: 0 (the default) starts
        from the neighbour's optimum as it is; 1 from the first-order prediction of the
        new optimum. Off by default: on the paper sweep it saved no iterations at these
        warm-start settings and costs a KKT factorization per start
        (``benchmarks/warm_start_predictor.py``, figures in benchmarks/README.md).
    call_time_limit_s : float
        The longest one solver call may run [s, wall clock] (``--call-time-limit``):
        IPOPT's ``max_wall_time`` and the condensed NLP's deadline; a cold start or a warm
        solve, all its calls together, may run
        :data:`~optimize.problem.deadline.COLD_START_CALLS` times as long
        (:mod:`optimize.problem.deadline`). A call stopped there fails with the status
        ``Wall_Time_Limit``; raise it for a large mesh, a slow machine or a loaded one.
    """

    solver: str = "ipopt"
    tol: float = 1e-6
    acceptable_tol: float = 1e-4
    max_iter: int = 1000
    warm_mu_init: float = 1e-4
    warm_bound_push: float = 1e-2
    stored_guess: bool = True
    start_file: str | None = None
    linear_solver: str = "mumps"
    mumps_pivot_order: int = 0
    transcription: str = "collocation"
    codegen: bool = False
    predictor_step: float = 0.0
    call_time_limit_s: float = CALL_WALL_LIMIT_S

    def __post_init__(self) -> None:
        if not self.call_time_limit_s > 0:
            raise ValueError(f"call_time_limit_s (--call-time-limit) must be positive [s], "
                             f"got {self.call_time_limit_s}")
        if self.solver not in SOLVERS:
            raise ValueError(f"solver must be one of {', '.join(SOLVERS)}, got {self.solver!r}")
        if self.transcription not in TRANSCRIPTIONS:
            raise ValueError(f"transcription must be one of {', '.join(TRANSCRIPTIONS)}, "
                             f"got {self.transcription!r}")
        if not 0 < self.warm_bound_push <= 0.5:  # IPOPT's range of warm_start_bound_frac
            raise ValueError(f"warm_bound_push must be in (0, 0.5], got {self.warm_bound_push}")
        if not 0 <= self.predictor_step <= 1:
            raise ValueError(f"predictor_step must be in [0, 1], got {self.predictor_step}")

    @property
    def stagewise(self) -> bool:
        """Whether the solver takes the stage-wise layout (:data:`STAGEWISE_SOLVERS`)."""
        return self.solver in STAGEWISE_SOLVERS


@dataclass(frozen=True)
class OcpOptions:
    """All options of the OCP: one :class:`Discretization` and :class:`SolverOptions`
    each (defaults: the default of each group)."""

    discretization: Discretization = field(default_factory=Discretization)
    solver: SolverOptions = field(default_factory=SolverOptions)

    def replace(self, **groups: dict[str, Any]) -> OcpOptions:
        """These options with fields of groups replaced, e.g.
        ``options.replace(solver={"tol": 1e-8})``."""
        unknown = set(groups) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise TypeError(f"unknown option groups: {', '.join(sorted(unknown))}")
        return dataclasses.replace(self, **{
            name: dataclasses.replace(getattr(self, name), **changes)
            for name, changes in groups.items()})

    def as_dict(self) -> dict[str, dict[str, Any]]:
        """``{group: {field: value}}`` (JSON-ready; :meth:`from_dict` reads it back)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, raw: dict[str, Any]) -> OcpOptions:
        """Options from :meth:`as_dict` output (lists back to tuples).

        Raises
        ------
        TypeError, ValueError
            An unknown group or field, or a value out of range.
        """
        if not isinstance(raw, dict):
            raise TypeError(f"OCP options must be a mapping of groups, got {type(raw).__name__}")
        types = {f.name: f.default_factory for f in dataclasses.fields(cls)}
        unknown = set(raw) - set(types)
        if unknown:
            raise TypeError(f"unknown option groups: {', '.join(sorted(unknown))}")
        groups = {}
        for name, values in raw.items():
            if not isinstance(values, dict):
                raise TypeError(f"option group {name}: not a mapping")
            groups[name] = types[name](**{k: tuple(v) if isinstance(v, list) else v
                                          for k, v in values.items()})
        return cls(**groups)
