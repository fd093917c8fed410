"""Run one warm-start chain on a worker: solves, retries and the cut-in search.

A chain (:class:`optimize.sweep.plan.Chain`) is shipped to a worker as one task
(:func:`run_chain`). The worker builds the NLP once per process (cached on the
options and the drive-model hash), then solves the chain's steps in order,
keeping the primal/dual solution of every converged scenario in memory to
warm-start the next ones. After the grid, it can search the cut-in wind speed
(net electrical power crossing zero) of each requested kind by bisection
between grid speeds, every probe warm-started from the nearer bracket end.

The numerical work goes through a *backend* (:class:`OcpBackend` by default,
the CasADi/IPOPT OCP of this package); anything with the same three methods
works, which is how the tests drive the chain logic with a cheap exact solver.
"""

from __future__ import annotations

import dataclasses
import math
import os
import socket
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from optimize.kinds import KINDS
from optimize.problem.scenario import scenario_name
from optimize.sweep.plan import Chain, Step

#: warm-started attempts per step before the cold-start fallback
MAX_WARM_ATTEMPTS = 2


class SolveResult(Protocol):
    """What the chain runner reads from a solve result (see ``optimize.solve.result.OcpResult``)."""

    status: str
    success: bool
    iterations: int
    wall_time_s: float
    avg_p_elec_w: float
    warm: Any


class Backend(Protocol):
    """The numerical side of a chain: build once, then solve warm or cold."""

    def build(self, problem: Problem) -> Any:
        """Build (or fetch from the per-process cache) the NLP for ``problem``."""

    def solve(self, ocp: Any, kind: str, wind_speed_m_s: float, warm: Any) -> SolveResult:
        """Solve one scenario warm-started from ``warm`` (a previous result's ``warm``)."""

    def cold_start(self, ocp: Any, kind: str, wind_speed_m_s: float) -> SolveResult:
        """Solve one scenario with no neighbouring solution (stored guess or homotopy)."""


@dataclass(frozen=True)
class Problem:
    """Everything a worker needs to build the NLP (all picklable).

    Attributes
    ----------
    params : tuple or None
        Arguments of ``optimize.model.kite_model.kite_dae`` (``KiteParams``,
        ``AeroCoefficients``, ``WindModel``); ``None`` for the package defaults.
        Plain data, so the DAE is built in the worker.
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

    params: Any
    drive_model: Any
    options: Any
    key: str
    system: Any = None

    @classmethod
    def for_system(cls, system: Any, drive_model: Any, options: Any) -> Problem:
        """The problem of a system with its options (already holding the system's limits)."""
        return cls(system.model_params(), drive_model, options,
                   problem_key(options, drive_model, system), system)


def problem_key(options: Any, drive_model: Any, system: Any) -> str:
    """NLP cache key: options, drive-model hash and system hash."""
    return f"{options!r}|{drive_model.sha256}|{getattr(system, 'sha256', 'defaults')}"


@dataclass(frozen=True)
class Attempt:
    """One solver run of a step: its warm source (``None`` = cold start) and outcome."""

    source: str | None
    status: str
    success: bool
    iterations: int
    wall_time_s: float


@dataclass(frozen=True)
class Resolve:
    """A re-solve of a scenario off its kind's smooth curve, from a neighbouring optimum.

    Attributes
    ----------
    attempt : Attempt
        The solver run (``source`` is the neighbour it started from).
    objective_w : float
        Average power of the objective (electrical or mechanical) it reached [W]
        (NaN when it failed).
    before_w : float
        The scenario's objective power before it [W].
    kept : bool
        It converged to a better optimum (by more than :func:`better_margin_w`) and
        replaced the scenario's result.
    """

    attempt: Attempt
    objective_w: float
    before_w: float
    kept: bool


@dataclass(frozen=True)
class ScenarioOutcome:
    """The final result of one scenario and how it was reached.

    Attributes
    ----------
    name, kind : str
        Scenario name (``"elec-lim-7.0"``) and kind (``"elec-lim"``).
    wind_speed_m_s : float
        Wind speed at 100 m [m/s].
    chain : int
        Index of the chain (worker task) that solved it.
    attempts : tuple of Attempt
        Every solver run, in order; the last one is the final result.
    result : Any or None
        The backend's result of the last attempt (``None`` if it raised).
    resolves : tuple of Resolve
        Re-solves from neighbours because the scenario sat off its kind's smooth
        curve (:func:`resolve_local_optima`); a kept one is also the last attempt.
    """

    name: str
    kind: str
    wind_speed_m_s: float
    chain: int
    attempts: tuple[Attempt, ...]
    result: Any | None
    resolves: tuple[Resolve, ...] = ()

    @property
    def objective(self) -> str:
        """``"electrical"`` or ``"mechanical"``."""
        return KINDS[self.kind][0]

    @property
    def drive_limits(self) -> bool:
        """Whether the drive limits applied."""
        return KINDS[self.kind][1]

    @property
    def success(self) -> bool:
        """Whether the final attempt converged."""
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
        ``"never generates on the grid"``, ``"too few converged grid speeds"`` or
        ``"probe failed at W m/s"`` (then the bracket is the last good one).
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
class ChainTask:
    """A chain with its problem, shipped to a worker as one task.

    Attributes
    ----------
    chain : Chain
    problem : Problem
    cut_in_kinds : tuple of str
        Kinds of this chain whose cut-in speed is searched after the grid.
    cut_in_tol_m_s : float
        Bisection stops when the bracket is at most this wide [m/s].
    """

    chain: Chain
    problem: Problem
    cut_in_kinds: tuple[str, ...] = ()
    cut_in_tol_m_s: float = 0.05


@dataclass(frozen=True)
class ChainOutcome:
    """What a worker sends back.

    Attributes
    ----------
    chain : int
    outcomes : tuple of ScenarioOutcome
        One per step, in solve order.
    cut_ins : tuple of CutIn
    build_time_s : float
        Time to build the NLP [s]; near zero when the per-process cache had it.
    worker : str
        ``host:pid`` of the process that ran the chain.
    """

    chain: int
    outcomes: tuple[ScenarioOutcome, ...]
    cut_ins: tuple[CutIn, ...] = ()
    build_time_s: float = 0.0
    worker: str = ""


# ------------------------------------------------------------------ the real backend
#: per-process NLP cache: (Problem.key, thread id) -> built OCP. Per thread, because
#: a CasADi solver object must not be used by two threads at once.
_OCP_CACHE: dict[tuple[str, int], Any] = {}


class OcpBackend:
    """The CasADi/IPOPT OCP of this package (:mod:`optimize.problem.ocp`, solved by
    :mod:`optimize.solve.solve`)."""

    def build(self, problem: Problem) -> Any:
        """Build the NLP once per process and per :attr:`Problem.key`."""
        from optimize.model.kite_model import kite_dae
        from optimize.problem.ocp import build_ocp

        key = (problem.key, threading.get_ident())
        if key not in _OCP_CACHE:
            dae = kite_dae(*(problem.params or ()))
            _OCP_CACHE[key] = build_ocp(dae, problem.drive_model, problem.options,
                                        system=problem.system)
        return _OCP_CACHE[key]

    @staticmethod
    def scenario(kind: str, wind_speed_m_s: float) -> Any:
        """The OCP's ``Scenario`` for a kind and wind speed [m/s]."""
        from optimize.problem.scenario import Scenario

        objective, limits = KINDS[kind]
        return Scenario(wind_speed_m_s=wind_speed_m_s, objective=objective, drive_limits=limits)

    def solve(self, ocp: Any, kind: str, wind_speed_m_s: float, warm: Any) -> SolveResult:
        """Warm-started solve (primal and dual start; on failure ``solve`` retries the same
        primal point once with cold barrier settings, before the chain's own fallbacks)."""
        from optimize.solve.solve import solve

        return solve(ocp, self.scenario(kind, wind_speed_m_s), warm)

    def cold_start(self, ocp: Any, kind: str, wind_speed_m_s: float) -> SolveResult:
        """From the stored initial guess when it fits, else the homotopy."""
        from optimize.solve.solve import start

        return start(ocp, self.scenario(kind, wind_speed_m_s))


# ------------------------------------------------------------------ the chain runner
def _attempt(
    backend: Backend, ocp: Any, kind: str, wind: float, source: str | None, warm: Any
) -> tuple[Attempt, Any | None]:
    t0 = time.perf_counter()
    try:
        if source is None:
            result = backend.cold_start(ocp, kind, wind)
        else:
            result = backend.solve(ocp, kind, wind, warm)
    except Exception as exc:  # a solver crash is a failed attempt, not a failed sweep
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return Attempt(source, f"exception: {last}", False, 0, time.perf_counter() - t0), None
    ok = bool(result.success) and math.isfinite(float(result.avg_p_elec_w))
    return (
        Attempt(source, str(result.status), ok, int(result.iterations), float(result.wall_time_s)),
        result,
    )


def solve_step(
    backend: Backend, ocp: Any, step: Step, warm: dict[str, Any], chain: int = 0
) -> ScenarioOutcome:
    """Solve one step: primary warm source, then fallbacks, then a cold start.

    Parameters
    ----------
    backend : Backend
    ocp : Any
        The built NLP.
    step : Step
    warm : dict
        Scenario name -> warm-start data of every converged scenario so far;
        sources missing here (failed or not solved) are skipped.
    chain : int
        Chain index recorded in the outcome.
    """
    attempts: list[Attempt] = []
    result = None
    sources = [s for s in (step.warm_from, *step.fallbacks) if s is not None and s in warm]
    for src in sources[:MAX_WARM_ATTEMPTS]:
        attempt, result = _attempt(backend, ocp, step.kind, step.wind_speed_m_s, src, warm[src])
        attempts.append(attempt)
        if attempt.success:
            break
    if not attempts or not attempts[-1].success:
        attempt, result = _attempt(backend, ocp, step.kind, step.wind_speed_m_s, None, None)
        attempts.append(attempt)
    return ScenarioOutcome(
        step.name, step.kind, step.wind_speed_m_s, chain, tuple(attempts), result
    )


def find_cut_in(
    backend: Backend,
    ocp: Any,
    kind: str,
    grid: dict[float, tuple[float, Any]],
    tol_m_s: float = 0.05,
) -> CutIn:
    """Bisection on the wind speed for zero average electrical power.

    Parameters
    ----------
    backend, ocp
        As for :func:`solve_step`.
    kind : str
    grid : dict
        Converged grid points of ``kind``: wind [m/s] -> (average electrical
        power [W], warm-start data).
    tol_m_s : float
        Final bracket width [m/s].

    Notes
    -----
    The bracket is the lowest pair of neighbouring converged grid speeds where
    the drive consumes (P_elec > 0) at the lower one and generates (P_elec <= 0)
    at the upper one. Each probe is warm-started from the nearer bracket end
    (the other end if that fails). The estimate is the linear interpolation of
    the crossing inside the final bracket.
    """
    nan = float("nan")
    winds = sorted(grid)
    if len(winds) < 2:
        return CutIn(kind, nan, nan, nan, "too few converged grid speeds")
    if all(grid[w][0] <= 0 for w in winds):
        return CutIn(kind, nan, nan, winds[0], "generates at every converged grid speed")
    pair = next(
        ((a, b) for a, b in zip(winds, winds[1:], strict=False) if grid[a][0] > 0 >= grid[b][0]),
        None,
    )
    if pair is None:
        return CutIn(kind, nan, winds[-1], nan, "never generates on the grid")
    (lo, hi), probes = pair, []
    (p_lo, w_lo), (p_hi, w_hi) = grid[lo], grid[hi]
    status = "found"
    while hi - lo > tol_m_s:
        mid = 0.5 * (lo + hi)
        ends = [(lo, w_lo), (hi, w_hi)] if mid - lo < hi - mid else [(hi, w_hi), (lo, w_lo)]
        result = None
        for end_wind, end_warm in ends:
            attempt, result = _attempt(
                backend, ocp, kind, mid, scenario_name(kind, end_wind), end_warm
            )
            if attempt.success:
                break
        p_mid = float(result.avg_p_elec_w) if result is not None else nan
        probes.append((mid, p_mid, attempt.success, attempt.status))
        if not attempt.success:
            status = f"probe failed at {mid:g} m/s"
            break
        if p_mid > 0:
            lo, p_lo, w_lo = mid, p_mid, result.warm
        else:
            hi, p_hi, w_hi = mid, p_mid, result.warm
    cut_in = lo + (hi - lo) * p_lo / (p_lo - p_hi) if status == "found" else nan
    return CutIn(kind, cut_in, lo, hi, status, tuple(probes))


# ------------------------------------------------------------------ local optima
#: a scenario whose objective power departs from the smooth curve through its
#: neighbours of the same kind by more than this fraction of the kind's largest |power|,
#: or whose period departs by more than :data:`JUMP_PERIOD_RTOL` of its own, is re-solved
#: from its neighbours. On the paper's 20 optima (4:10:1.5) the interior points depart
#: by at most 0.02 and 0.14 (where a drive limit starts to bind); the local optima of
#: the issue that led here were 0.05 of the power
JUMP_POWER_RTOL = 0.03
JUMP_PERIOD_RTOL = 0.15
#: neighbours on each side of the smooth curve's local fit
CURVE_NEIGHBOURS = 2
#: rounds of detection and re-solve per kind (a kept re-solve can reveal the next one)
MAX_RESOLVE_ROUNDS = 3


def objective_power_w(kind: str, result: Any) -> float:
    """Average power [W] the kind's objective maximizes (negative = generated); NaN if absent."""
    name = "avg_p_elec_w" if KINDS[kind][0] == "electrical" else "avg_p_mech_w"
    value = getattr(result, name, math.nan)
    return float(value) if value is not None else math.nan


def better_margin_w(power_w: float) -> float:
    """How much lower [W] a re-solve's objective power must be to count as a better
    optimum: 0.05 W or 1e-4 of the power, whichever is larger (solver tolerance)."""
    return max(0.05, 1e-4 * abs(power_w))


def _curve_prediction(winds: list[float], values: list[float], i: int) -> float:
    """``values[i]`` predicted from its nearest neighbours by a local polynomial; NaN
    with fewer than two.

    Inside the grid: the least-squares quadratic through up to :data:`CURVE_NEIGHBOURS`
    points on each side (exact for a cubic on an even grid: the cubic term is odd about
    the point). At an end: the polynomial through the nearest up to
    ``2 CURVE_NEIGHBOURS`` points on the one side (a cubic through four).
    """
    below, above = list(range(i)), list(range(i + 1, len(winds)))
    if below and above:
        near, degree = below[-CURVE_NEIGHBOURS:] + above[:CURVE_NEIGHBOURS], 2
    else:  # winds are increasing: the nearest on the one side
        near, degree = (below[-2 * CURVE_NEIGHBOURS:] or above[:2 * CURVE_NEIGHBOURS]), 3
    if len(near) < 2:
        return math.nan
    x = np.array([winds[j] for j in near]) - winds[i]
    y = np.array([values[j] for j in near])
    coef = np.polyfit(x, y, min(degree, len(near) - 1))
    return float(coef[-1])


def off_curve(winds: list[float], power_w: list[float], period_s: list[float]) -> list[int]:
    """Indices of the points of one kind that sit off the smooth curve of the others.

    Parameters
    ----------
    winds : list of float
        Wind speeds [m/s], increasing.
    power_w : list of float
        Objective power at each [W].
    period_s : list of float
        Period at each [s] (NaN where unknown: then only the power is checked).

    Returns
    -------
    list of int
        Points whose power departs from the local fit of their neighbours by more
        than :data:`JUMP_POWER_RTOL` of the kind's largest ``|P|``, or whose period
        departs by more than :data:`JUMP_PERIOD_RTOL` of its own.
    """
    if len(winds) < 3:
        return []
    scale = max(abs(p) for p in power_w)
    flagged = []
    for i in range(len(winds)):
        p_fit = _curve_prediction(winds, power_w, i)
        jump = abs(power_w[i] - p_fit) > JUMP_POWER_RTOL * scale
        if math.isfinite(period_s[i]):
            t_fit = _curve_prediction(winds, period_s, i)
            jump = jump or abs(period_s[i] - t_fit) > JUMP_PERIOD_RTOL * period_s[i]
        if jump:
            flagged.append(i)
    return flagged


def resolve_local_optima(
    backend: Backend, ocp: Any, outcomes: list[ScenarioOutcome], warm: dict[str, Any]
) -> list[ScenarioOutcome]:
    """Re-solve scenarios that sit off their kind's smooth curve from their neighbours.

    A cold start or a chain can land on a local optimum: one wind speed of a kind then
    disagrees with the curve through its neighbours (a jump in average power or
    period, :func:`off_curve`). Each such scenario is solved again, warm-started from
    each converged neighbouring wind speed of its kind other than the one its result
    came from, and the better optimum (lower objective power by more than
    :func:`better_margin_w`) is kept. Every re-solve is recorded in the outcome's
    ``resolves``; ``warm`` is updated with the kept solutions.

    Returns
    -------
    list of ScenarioOutcome
        ``outcomes`` in the same order, re-solved ones replaced.
    """
    out = list(outcomes)
    version = dict.fromkeys((o.name for o in out), 0)  # bumped when a result is replaced
    tried: set[tuple[str, str, int]] = set()
    for kind in dict.fromkeys(o.kind for o in out):
        for _ in range(MAX_RESOLVE_ROUNDS):
            idx = sorted((i for i, o in enumerate(out) if o.kind == kind and o.success),
                         key=lambda i: out[i].wind_speed_m_s)
            power = [objective_power_w(kind, out[i].result) for i in idx]
            period = [float(getattr(out[i].result, "period_s", math.nan)) for i in idx]
            if not all(math.isfinite(p) for p in power):
                break
            winds = [out[i].wind_speed_m_s for i in idx]
            replaced = False
            for k in off_curve(winds, power, period):
                o = out[idx[k]]
                for n in (k - 1, k + 1):
                    if not 0 <= n < len(idx):
                        continue
                    src = out[idx[n]]
                    key = (o.name, src.name, version[src.name])
                    if key in tried or (o.attempts[-1].source == src.name
                                        and version[src.name] == 0):
                        continue
                    tried.add(key)
                    before = objective_power_w(kind, o.result)
                    attempt, result = _attempt(backend, ocp, kind, o.wind_speed_m_s,
                                               src.name, warm[src.name])
                    after = (objective_power_w(kind, result) if attempt.success
                             else math.nan)
                    kept = bool(attempt.success and after < before - better_margin_w(before))
                    record = Resolve(attempt, after, before, kept)
                    if kept:
                        o = dataclasses.replace(o, attempts=(*o.attempts, attempt),
                                                result=result, resolves=(*o.resolves, record))
                        warm[o.name] = result.warm
                        version[o.name] += 1
                        replaced = True
                    else:
                        o = dataclasses.replace(o, resolves=(*o.resolves, record))
                    out[idx[k]] = o
                    if kept:  # the next round checks the curve again with it
                        break
            if not replaced:
                break
    return out


def run_chain(
    task: ChainTask, backend: Backend | None = None, progress: Any = None
) -> ChainOutcome:
    """Run a whole chain on this worker (the function submitted to the executor).

    Parameters
    ----------
    task : ChainTask
    backend : Backend, optional
        Defaults to :class:`OcpBackend`.
    progress : object with ``put(dict)``, optional
        Receives ``{"chain", "name", "success", "status", "wall_time_s"}`` after
        every scenario and ``{"chain", "cut_in": kind}`` after each cut-in search.

    Returns
    -------
    ChainOutcome
    """
    backend = backend or OcpBackend()
    t0 = time.perf_counter()
    ocp = backend.build(task.problem)
    build_time_s = time.perf_counter() - t0
    chain: Chain = task.chain
    warm: dict[str, Any] = {}
    outcomes: list[ScenarioOutcome] = []
    for step in chain.steps:
        outcome = solve_step(backend, ocp, step, warm, chain.index)
        if outcome.success:
            warm[outcome.name] = outcome.result.warm
        outcomes.append(outcome)
        if progress is not None:
            progress.put(
                {
                    "chain": chain.index,
                    "name": outcome.name,
                    "success": outcome.success,
                    "status": outcome.status,
                    "wall_time_s": outcome.total_wall_time_s,
                }
            )
    outcomes = resolve_local_optima(backend, ocp, outcomes, warm)
    cut_ins = []
    for kind in task.cut_in_kinds:
        grid = {
            o.wind_speed_m_s: (float(o.result.avg_p_elec_w), o.result.warm)
            for o in outcomes
            if o.kind == kind and o.success
        }
        cut_ins.append(find_cut_in(backend, ocp, kind, grid, task.cut_in_tol_m_s))
        if progress is not None:
            progress.put({"chain": chain.index, "cut_in": kind})
    return ChainOutcome(
        chain.index,
        tuple(outcomes),
        tuple(cut_ins),
        build_time_s,
        f"{socket.gethostname()}:{os.getpid()}",
    )


# ------------------------------------------------------------------ the driver side
@dataclass(frozen=True)
class SweepResult:
    """All chains of a sweep, gathered in the driver.

    Attributes
    ----------
    outcomes : tuple of ScenarioOutcome
        One per scenario, sorted by kind (as selected) then wind speed.
    cut_ins : tuple of CutIn
    chains : tuple of ChainOutcome
        Per-chain records (worker, NLP build time); their outcomes are those above.
    wall_time_s : float
        Wall time of the whole sweep, cold starts included [s].
    executor : str
        Description of the executor it ran on.
    """

    outcomes: tuple[ScenarioOutcome, ...]
    cut_ins: tuple[CutIn, ...]
    chains: tuple[ChainOutcome, ...]
    wall_time_s: float
    executor: str


def _failed_chain(task: ChainTask, exc: BaseException) -> ChainOutcome:
    last = traceback.format_exception_only(type(exc), exc)[-1].strip()
    status = f"worker error: {last}"
    outcomes = tuple(
        ScenarioOutcome(
            s.name,
            s.kind,
            s.wind_speed_m_s,
            task.chain.index,
            (Attempt(s.warm_from, status, False, 0, 0.0),),
            None,
        )
        for s in task.chain.steps
    )
    cut_ins = tuple(CutIn(k, math.nan, math.nan, math.nan, status) for k in task.cut_in_kinds)
    return ChainOutcome(task.chain.index, outcomes, cut_ins)


def run_sweep(
    tasks: tuple[ChainTask, ...],
    executor: Any,
    channel: Any = None,
    description: str = "",
    backend: Backend | None = None,
    show_progress: bool = True,
) -> SweepResult:
    """Run every chain task on ``executor`` and gather the outcomes.

    Parameters
    ----------
    tasks : tuple of ChainTask
        From :func:`make_tasks`.
    executor : Executor
        Any ``concurrent.futures`` executor (see :mod:`optimize.sweep.executors`).
    channel : optional
        Progress channel matching the executor; without it the bar moves
        only when a whole chain finishes.
    description : str
        Executor description for the record.
    backend : Backend, optional
        Passed to :func:`run_chain` (must be picklable for process executors).
    show_progress : bool
        Show a tqdm bar (one tick per scenario and per cut-in search).

    Returns
    -------
    SweepResult
        A chain whose task raised is recorded with every scenario failed
        (status ``worker error: ...``); nothing is silently dropped.
    """
    from functools import partial

    from tqdm import tqdm

    from optimize.sweep.executors import run_tasks

    total = sum(len(t.chain.steps) + len(t.cut_in_kinds) for t in tasks)
    bar = tqdm(total=total, desc="optimize", unit="solve", disable=not show_progress)
    n_failed = 0

    def on_event(event: dict) -> None:
        nonlocal n_failed
        if "name" in event:
            n_failed += 0 if event["success"] else 1
            bar.set_postfix_str(f"{event['name']}: {event['status']}, failed {n_failed}")
        else:
            bar.set_postfix_str(f"cut-in {event['cut_in']} done")
        bar.update(1)

    fn = run_chain if backend is None else partial(run_chain, backend=backend)
    t0 = time.perf_counter()
    try:
        futures = run_tasks(executor, fn, tasks, channel, on_event)
    finally:
        wall = time.perf_counter() - t0
    chains = []
    for task, fut in zip(tasks, futures, strict=True):
        exc = fut.exception()
        chains.append(_failed_chain(task, exc) if exc is not None else fut.result())
    bar.update(total - bar.n)
    bar.close()
    order = {k: i for i, k in enumerate(k for t in tasks for k in t.chain.kinds)}
    outcomes = sorted(
        (o for c in chains for o in c.outcomes), key=lambda o: (order[o.kind], o.wind_speed_m_s)
    )
    cut_ins = tuple(ci for c in chains for ci in c.cut_ins)
    return SweepResult(tuple(outcomes), cut_ins, tuple(chains), wall, description)


def make_tasks(
    chains: tuple[Chain, ...],
    problem: Problem,
    cut_in_kinds: tuple[str, ...] = (),
    cut_in_tol_m_s: float = 0.05,
) -> tuple[ChainTask, ...]:
    """One task per chain; each cut-in search goes to the chain that solved its kind."""
    return tuple(
        ChainTask(c, problem, tuple(k for k in c.kinds if k in cut_in_kinds), cut_in_tol_m_s)
        for c in chains
    )
