"""What the solve service reports: attempts, scenario outcomes, cut-in searches, chains.

Every failure is said one way, :func:`failure_status`: a solver crash is
``"exception: <type>: <message>"`` (a failed attempt of that speed, never a failed
sweep), a worker that died is ``"worker error: <type>: <message>"`` for every
speed of its chain; a solver that ran and did not converge gives its own status.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from optimize.problem.scenario import Scenario

#: failure status prefixes (:func:`failure_status`)
CRASH, WORKER_ERROR = "exception", "worker error"
#: the status prefix of a solve never run: its executor was lost first (a Dask cluster)
NOT_RUN = "not run"


def failure_status(prefix: str, exc: BaseException) -> str:
    """``"<prefix>: <type>: <message>"`` (at most 300 characters): the one failure format."""
    return f"{prefix}: {type(exc).__name__}: {exc}"[:300]


def transient(record: dict) -> bool:
    """Whether a solve record failed by a crash of the solver or its worker, or was never
    run (not stored, so a re-run tries it again), not by the solver's own verdict."""
    return not record["success"] and str(record["status"]).startswith((CRASH, WORKER_ERROR,
                                                                       NOT_RUN))


def failure_reason(record: dict) -> str:
    """Why a failed solve record failed: its result check's reasons when the solver
    converged to an optimum that cannot stand, else the solver's status."""
    check = record.get("result_check") or ""
    return check if check.startswith("failed") else str(record["status"])


@dataclass(frozen=True)
class Attempt:
    """One solver run of a scenario: its warm source (``None`` = cold start) and outcome.

    ``source`` is the scenario name (``"elec-lim-7.0"``) whose solution started it.
    ``success`` is True when the solver converged and its optimum passed the result
    check; ``check`` is that check (:class:`optimize.analysis.result_check.ResultCheck`,
    None when the solver did not converge or its backend checks nothing).
    ``intermediate_points`` and ``intermediate_iterations`` are the converged points
    and the solver iterations on the way from the source that are not the scenario's
    own (:mod:`optimize.solve.starts.continuation`; not in ``iterations``).
    """

    source: str | None
    status: str
    success: bool
    iterations: int
    wall_time_s: float
    check: Any = None
    intermediate_points: int = 0
    intermediate_iterations: int = 0

    @property
    def all_iterations(self) -> int:
        """Solver iterations of this run, the way to the scenario included."""
        return self.iterations + self.intermediate_iterations

    @property
    def verdict(self) -> str:
        """The result check's ``"passed"`` or ``"failed: <reasons>"``; ``""`` unchecked."""
        return "" if self.check is None else self.check.verdict()


@dataclass(frozen=True)
class Resolve:
    """A re-solve of a scenario: off its kind's smooth curve, from a neighbouring optimum
    (:mod:`optimize.service.local_optima`), or by the period scan, from its own optimum
    with the period held elsewhere (:mod:`optimize.service.period_scan`).

    Attributes
    ----------
    attempt : Attempt
        The solver run (``source`` is the neighbour it started from, or the held start
        ``"mech-free-10.0 held at 45 s"``; when the held solve failed, that solve).
    objective_w : float
        Average power of the objective (electrical or mechanical) it reached [W]
        (NaN when it failed).
    before_w : float
        The scenario's objective power before it [W].
    kept : bool
        It converged to a better optimum (by more than
        :func:`optimize.service.local_optima.better_margin_w`) and replaced the
        scenario's result.
    held_period_s : float or None
        The period scan's held period [s]; None for a re-solve from a neighbour.
    carried : bool
        It carried a neighbour's better optimum on along the kind (the neighbour was not
        off the curve itself, but had just been re-solved to a better optimum).
    back : bool
        It offered back a neighbour's better optimum that a carried re-solve from this
        scenario's had found.
    """

    attempt: Attempt
    objective_w: float
    before_w: float
    kept: bool
    held_period_s: float | None = None
    carried: bool = False
    back: bool = False


@dataclass(frozen=True)
class ScenarioOutcome:
    """The final result of one scenario and how it was reached.

    Attributes
    ----------
    scenario : Scenario
        The scenario (kind and wind speed at 100 m).
    chain : int
        Index of the chain (worker task) that solved it.
    attempts : tuple of Attempt
        Every solver run, in order; the last one is the final result.
    result : Any or None
        The backend's result of the last attempt (``None`` if it raised).
    resolves : tuple of Resolve
        Re-solves from neighbours because the scenario sat off its kind's smooth
        curve (:func:`optimize.service.local_optima.resolve_local_optima`); a kept
        one is also the last attempt.
    depth : int
        Solves before this one along its starts: 0 for a cold start (stored guess or
        homotopy), else one more than the depth the scenario of :attr:`warm_source` had
        when it started this one (:class:`optimize.service.solves.Solves`).
    """

    scenario: Scenario
    chain: int
    attempts: tuple[Attempt, ...]
    result: Any | None
    resolves: tuple[Resolve, ...] = ()
    depth: int = 0

    @property
    def check(self) -> str:
        """The result check's verdict on the final optimum (``"passed"`` or ``"failed:
        <reasons>"``, :mod:`optimize.analysis.result_check`); ``""`` when not checked.
        A failed check makes the scenario a failed one."""
        return self.attempts[-1].verdict if self.attempts else ""

    @property
    def name(self) -> str:
        """The scenario's name (``"elec-lim-7.0"``)."""
        return self.scenario.name

    @property
    def kind(self) -> str:
        """The scenario's kind (``"elec-lim"``)."""
        return self.scenario.kind

    @property
    def wind_speed_m_s(self) -> float:
        """The scenario's wind speed at 100 m [m/s]."""
        return self.scenario.wind_speed_m_s

    @property
    def objective(self) -> str:
        """``"electrical"`` or ``"mechanical"``."""
        return self.scenario.objective

    @property
    def drive_limits(self) -> bool:
        """Whether the drive limits applied."""
        return self.scenario.drive_limits

    @property
    def success(self) -> bool:
        """Whether the final attempt converged and its optimum passed the result check."""
        return bool(self.attempts) and self.attempts[-1].success

    @property
    def status(self) -> str:
        """Solver status string of the final attempt."""
        return self.attempts[-1].status if self.attempts else "not attempted"

    @property
    def warm_source(self) -> str:
        """Warm source of the final attempt: a scenario name, ``"stored guess"`` or
        ``"cold start"`` (the homotopy)."""
        if not self.attempts:
            return ""
        src = self.attempts[-1].source
        if src is not None:
            return src
        stored = getattr(self.result, "start", None) == "stored guess"  # OcpResult.start
        return "stored guess" if stored else "cold start"

    @property
    def total_wall_time_s(self) -> float:
        """Wall time of all attempts together, discarded re-solves included [s]."""
        return (sum(a.wall_time_s for a in self.attempts)
                + sum(r.attempt.wall_time_s for r in self.resolves if not r.kept))


@dataclass(frozen=True)
class CutIn:
    """Cut-in wind speed of one kind: where the average electrical power crosses zero.

    Attributes
    ----------
    kind : str
    cut_in_m_s : float
        Linear interpolation of the zero crossing inside the final bracket [m/s];
        NaN when there is no crossing on the grid or the search failed.
    bracket_lo_m_s, bracket_hi_m_s : float
        Final bracket [m/s]: the drive consumes at ``lo`` and generates at ``hi``
        (NaN when not found).
    status : str
        ``"found"``, ``"generates at every converged grid speed"``,
        ``"never generates on the grid"``, ``"too few converged grid speeds"``,
        ``"probe failed at W m/s"`` (then the bracket is the last good one) or the
        chain's ``"worker error: ..."``.
    probes : tuple of (float, float, bool, str)
        Bisection probes: wind [m/s], average electrical power [W], converged,
        solver status.
    """

    kind: str
    cut_in_m_s: float
    bracket_lo_m_s: float
    bracket_hi_m_s: float
    status: str
    probes: tuple[tuple[float, float, bool, str], ...] = ()


@dataclass(frozen=True)
class ChainOutcome:
    """What a worker sends back for one chain.

    Attributes
    ----------
    chain : int
    outcomes : tuple of ScenarioOutcome
        One per planned step, in solve order (the grid of ``bench optimize``).
    records : tuple of dict
        Every solve's record (:meth:`optimize.service.solves.Solves.solve`), sorted by
        wind speed: planned, added by a refinement, cut-in probes.
    cut_ins : tuple of CutIn
    build_time_s : float
        Time to build the NLP [s]; near zero when the per-process cache had it.
    worker : str
        ``host:pid`` of the process that ran the chain.
    error : str
        ``"worker error: ..."`` when the chain's task raised (then every planned
        speed failed with it), else ``""``.
    iterations : dict of int
        Every solver iteration the chain ran (:attr:`Attempt.all_iterations` of its
        every solver run), by the run's role (``"grid"``, ``"retry"``, ``"local
        optimum"``, ``"period scan"``, ``"cut-in"``, ...).
    """

    chain: int
    outcomes: tuple[ScenarioOutcome, ...]
    records: tuple[dict, ...] = ()
    cut_ins: tuple[CutIn, ...] = ()
    build_time_s: float = 0.0
    worker: str = ""
    error: str = ""
    iterations: dict[str, int] = field(default_factory=dict)
