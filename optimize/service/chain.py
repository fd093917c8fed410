"""The one chain loop: the solves of one problem, in order, on one worker.

A chain (:class:`ChainTask`) is shipped to a worker as one task
(:func:`run_chain`). The worker's :class:`optimize.service.solves.Solves` takes in
the scenarios solved elsewhere that the task hands it (``solved``: warm starts, and
a grid to check), solves the chain's planned steps in order (one step of the start
graph, :func:`optimize.service.plan.plan_graph`, or a chain of
:func:`optimize.service.plan.chain_steps`: a cold start at the middle wind speed,
then outwards), each step warm-started from another problem's solution of its
scenario where the task offers one (``foreign``: a sizing candidate from its reference
drive, :mod:`optimize.service.foreign`), then from its planned source and fallbacks,
then, as asked:

* solves its failed scenarios again from the other starts it has
  (:func:`optimize.service.retry.retry_failed`);
* re-solves the planned scenarios that sit off their kind's smooth curve
  (:func:`optimize.service.local_optima.resolve_local_optima`);
* scans the period of each converged scenario for a better optimum
  (:func:`optimize.service.period_scan.scan_periods`);
* searches the cut-in wind speed of some kinds by bisection
  (:func:`optimize.service.cut_in.find_cut_in`);
* refines the wind grid of one kind where its power curve bends for a site
  (:class:`Refinement`, with the grid rule its caller hands in).

``bench optimize``, ``bench size`` and ``bench aep --refine`` all run their
solves through this loop (:mod:`optimize.service.run`).
"""

from __future__ import annotations

import os
import socket
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from optimize.problem.scenario import Scenario
from optimize.service.builder import Problem
from optimize.service.cut_in import find_cut_in
from optimize.service.foreign import CycleStart, ForeignStart
from optimize.service.local_optima import resolve_local_optima
from optimize.service.outcome import ChainOutcome, ScenarioOutcome
from optimize.service.period_scan import scan_periods
from optimize.service.plan import Step
from optimize.service.retry import retry_failed
from optimize.service.solves import Solves


@dataclass(frozen=True)
class Refinement:
    """Add the wind speeds where one kind's power curve bends for a site.

    Attributes
    ----------
    kind : str
    site : Weibull or Histogram
        The wind distribution (:mod:`energy.site`).
    grid : callable
        ``grid(power, start, site, known=, tol=, max_points=)``: picks the added speeds
        (:func:`energy.adaptive.refine_grid`, handed in by the caller: the service does
        not import the energy stage above it). A module-level function (picklable).
    tol, max_points : float or None, int or None
        ``grid``'s stop criterion and grid cap (None: its defaults).
    known : tuple of (float, float, ...)
        Points known without solving: wind speed [m/s], then one power [W] per curve of
        ``curves`` (e.g. the sweep's grid); their speeds are not solved.
    curves : tuple of str
        Record figures the refinement follows together (``avg_p_elec_w``, ``avg_p_mech_w``).
    check : bool
        Before the first added speed, solve again the known speed nearest it (role
        ``"check"``): the warm start of the added ones, and a check of the known figure.
    starts : tuple of CycleStart
        The known speeds' cycles (:class:`optimize.service.foreign.CycleStart`, e.g. the
        sweep's trajectories): the check re-solve starts from its own, and each added
        speed from the nearest solved speed, known or added (a cold start without them).
    """

    kind: str
    site: Any
    grid: Callable[..., Any]
    tol: float | None = None
    max_points: int | None = None
    known: tuple[tuple[float, ...], ...] = ()
    curves: tuple[str, ...] = ("avg_p_elec_w",)
    check: bool = False
    starts: tuple[CycleStart, ...] = ()


@dataclass(frozen=True)
class ChainTask:
    """One chain: a problem, its planned steps and what follows them (all picklable).

    Attributes
    ----------
    problem : Problem
    steps : tuple of Step
        Planned solves, in order (role ``"grid"``).
    index : int
        Chain index, recorded in outcomes and progress events.
    tag : tuple of (str, Any)
        Fields added to every record and progress event (e.g. ``("candidate", "x1")``).
    store : Path or None
        Folder of the stored solves (resume); None stores nothing.
    backend : optional
        The numerical side (:class:`optimize.service.builder.OcpBackend` by default).
    resolve : bool
        Re-solve planned scenarios off their kind's smooth curve.
    resolve_by_period : bool
        That check looks at the period as well as the power
        (:func:`optimize.service.local_optima.resolve_local_optima`'s ``by_period``).
    period_scan : int
        Held periods per converged scenario of the period scan, after the re-solves
        (:func:`optimize.service.period_scan.scan_periods`); 0 scans nothing.
    cut_in_kinds : tuple of str
        Kinds whose cut-in speed is searched after the grid.
    cut_in_tol_m_s : float
        Bisection stops when the bracket is at most this wide [m/s].
    refine : Refinement or None
    extras : callable or None
        ``extras(trajectory) -> dict`` of further record figures (picklable).
    solved : tuple of (ScenarioOutcome, dict)
        Scenarios solved by other tasks, with their records: warm starts for the
        steps, and part of the grid the re-solve, cut-in searches and refinement see
        (a re-solve may replace them); they come back in the outcome.
    starts : tuple of (ScenarioOutcome, dict)
        Further scenarios solved elsewhere, as warm starts only (not part of the grid,
        not in the outcome).
    retry : bool
        Solve the grid's failed scenarios again from the other starts there are
        (:func:`optimize.service.retry.retry_failed`), before the re-solve of local optima.
    foreign : tuple of ForeignStart
        Other problems' solutions, each the first start of this problem's scenario of
        its kind and wind speed (:mod:`optimize.service.foreign`).
    """

    problem: Problem
    steps: tuple[Step, ...] = ()
    index: int = 0
    tag: tuple[tuple[str, Any], ...] = ()
    store: Path | None = None
    backend: Any = None
    resolve: bool = False
    resolve_by_period: bool = True
    period_scan: int = 0
    cut_in_kinds: tuple[str, ...] = ()
    cut_in_tol_m_s: float = 0.05
    refine: Refinement | None = None
    extras: Callable[[Any], dict] | None = None
    solved: tuple[tuple[ScenarioOutcome, dict], ...] = ()
    starts: tuple[tuple[ScenarioOutcome, dict], ...] = ()
    retry: bool = False
    foreign: tuple[ForeignStart, ...] = ()


def _nearest(solves: Solves, r: Refinement, scenario: Scenario) -> list:
    """The starts of an added speed: the nearest solved speeds of the refined kind, its
    own solves before the known cycles at equal distance, at most two."""
    own = solves.converged(r.kind)
    cycles = [s for s in r.starts if s.scenario not in own]
    ranked = sorted([*own, *cycles], key=lambda s: (
        abs((s.scenario if isinstance(s, CycleStart) else s).wind_speed_m_s
            - scenario.wind_speed_m_s), isinstance(s, CycleStart)))
    return ranked[:2]


def _refine(solves: Solves, r: Refinement, start: tuple[float, ...]) -> None:
    known = {float(w): (p[0] if len(p) == 1 else tuple(p)) for w, *p in r.known}
    cycles = {s.scenario.wind_speed_m_s: s for s in r.starts}

    def power(wind_speed_m_s: float) -> Any:
        added = Scenario.of_kind(r.kind, round(float(wind_speed_m_s), 6))
        if r.check and known and not any(rec["role"] == "check"
                                         for rec in solves.records.values()):
            near = min(known, key=lambda w: abs(w - added.wind_speed_m_s))
            solves.solve(added.at(near), "check", [cycles[near]] if near in cycles else None)
        rec = solves.solve(added, "added", _nearest(solves, r, added) or None)
        if not rec["success"]:
            return None
        values = tuple(rec[c] for c in r.curves)
        return values[0] if len(values) == 1 else values

    limits = {k: v for k, v in (("tol", r.tol), ("max_points", r.max_points)) if v is not None}
    r.grid(power, start, r.site, known=known, **limits)


def run_chain(task: ChainTask, progress: Any = None) -> ChainOutcome:
    """Run a whole chain on this worker (the function submitted to the executor).

    Parameters
    ----------
    task : ChainTask
    progress : object with ``put(dict)``, optional
        Receives the solves' event after every solve
        (:class:`optimize.service.solves.Solves`) and ``{"chain", "cut_in": kind}``
        after each cut-in search.

    Returns
    -------
    ChainOutcome
    """
    solves = Solves(task.problem, task.store, task.backend, progress, dict(task.tag),
                    task.extras, task.index)
    for outcome, record in (*task.solved, *task.starts):
        solves.adopt(outcome, record)
    solves.foreign.update((f.scenario, f) for f in task.foreign)
    grid = [o.scenario for o, _ in task.solved] + [s.scenario for s in task.steps]
    for step in task.steps:
        sources = [s for s in (step.warm_from, *step.fallbacks) if s in grid]
        solves.solve(step.scenario, "grid", sources)
    if task.retry:
        retry_failed(solves, grid)
    if task.resolve:
        resolve_local_optima(solves, [s for s in grid if s in solves.outcomes],
                             task.resolve_by_period)
    scan_periods(solves, [s for s in grid if s in solves.outcomes], task.period_scan)
    cut_ins = []
    for kind in task.cut_in_kinds:
        powers = {s.wind_speed_m_s: solves.records[s]["avg_p_elec_w"] for s in grid
                  if s.kind == kind and solves.records[s]["success"]}
        cut_ins.append(find_cut_in(solves, kind, powers, task.cut_in_tol_m_s))
        if progress is not None:
            progress.put({"chain": task.index, "cut_in": kind})
    if task.refine is not None:
        start = tuple(sorted(s.wind_speed_m_s for s in grid if s.kind == task.refine.kind))
        _refine(solves, task.refine, start)
    only_starts = {o.scenario for o, _ in task.starts}
    return ChainOutcome(
        task.index,
        tuple(solves.outcomes[s] for s in grid if s in solves.outcomes),
        tuple(solves.records[s] for s in sorted(solves.records, key=lambda s: s.wind_speed_m_s)
              if s not in only_starts),
        tuple(cut_ins),
        solves.build_time_s,
        f"{socket.gethostname()}:{os.getpid()}",
        iterations=dict(solves.iterations),
    )
