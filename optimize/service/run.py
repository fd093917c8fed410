"""Run chains on the local process pool or a Dask cluster; gather what they report.

* :func:`run_chains` submits each :class:`optimize.service.chain.ChainTask` as one
  executor task; a chain whose worker died reports every planned speed failed with
  status ``"worker error: <type>: <message>"`` (nothing is silently dropped);
* :func:`solve_tasks` solves a list of :class:`SolveTask` (``bench size``,
  ``bench aep --refine``): one chain per (problem, kind, tag), along the
  continuation order of its wind speeds; returns the solve records;
* :func:`run_sweep` runs ``bench optimize``'s planned chains
  (:func:`make_tasks`) with a progress bar; returns a :class:`SweepResult`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from optimize.service.builder import Problem
from optimize.service.chain import ChainTask, Refinement, run_chain
from optimize.service.local_optima import LOCAL_OPTIMUM
from optimize.service.outcome import (
    WORKER_ERROR,
    Attempt,
    ChainOutcome,
    CutIn,
    ScenarioOutcome,
    failure_status,
)
from optimize.service.plan import Chain, chain_steps
from optimize.service.solver import attempt_line
from optimize.service.store import solve_key


def failed_chain(task: ChainTask, exc: BaseException) -> ChainOutcome:
    """The outcome of a chain whose task raised: every planned speed failed, with the
    one failure format (:func:`optimize.service.outcome.failure_status`)."""
    status = failure_status(WORKER_ERROR, exc)
    outcomes = tuple(ScenarioOutcome(s.name, s.kind, s.wind_speed_m_s, task.index,
                                     (Attempt(s.warm_from, status, False, 0, 0.0),), None)
                     for s in task.steps)
    records = tuple({**dict(task.tag),
                     "key": (solve_key(task.problem, s.kind, s.wind_speed_m_s)
                             if task.store is not None else None),
                     "kind": s.kind, "wind_speed_m_s": s.wind_speed_m_s, "role": "grid",
                     "success": False, "status": status, "cached": False}
                    for s in sorted(task.steps, key=lambda s: s.wind_speed_m_s))
    cut_ins = tuple(CutIn(k, math.nan, math.nan, math.nan, status) for k in task.cut_in_kinds)
    return ChainOutcome(task.index, outcomes, records, cut_ins, error=status)


def run_chains(tasks: Sequence[ChainTask], handle: Any = None, *, workers: int = 2,
               scheduler: str | None = None,
               on_event: Callable[[dict], None] | None = None) -> tuple[list[ChainOutcome], str]:
    """Run every chain; their outcomes in task order and the executor's description.

    ``handle`` is an open :class:`optimize.service.executors.ExecutorHandle`; without
    it the local process pool of ``workers`` (or the Dask cluster at ``scheduler``)
    is opened for these chains. ``on_event`` receives the progress events.
    """
    from optimize.service.executors import open_executor, run_tasks

    if handle is None:
        with open_executor(workers, scheduler) as h:
            return run_chains(tasks, h, on_event=on_event)
    futures = run_tasks(handle.executor, run_chain, tasks, handle.channel, on_event)
    outs = [failed_chain(t, f.exception()) if f.exception() is not None else f.result()
            for t, f in zip(tasks, futures, strict=True)]
    return outs, handle.description


@dataclass(frozen=True)
class SolveTask:
    """One solve: a problem (system, drive model, options), a scenario kind, a wind speed.

    ``tag`` (e.g. ``(("candidate", "x1"),)``) is copied into the record and progress events.
    """

    problem: Problem
    kind: str
    wind_speed_m_s: float
    tag: tuple[tuple[str, Any], ...] = ()


def solve_tasks(tasks: Sequence[SolveTask], store: Path | None = None, *, workers: int = 2,
                scheduler: str | None = None, handle: Any = None, backend: Any = None,
                refine: Callable[[str], Refinement] | None = None,
                on_event: Callable[[dict], None] | None = None) -> list[dict]:
    """Solve every task; the records of each chain, sorted by wind speed, chain after chain.

    Tasks of one problem, kind and tag form one chain (one executor task), planned
    along the continuation order of their wind speeds
    (:func:`optimize.service.plan.chain_steps`). With ``refine`` (kind -> its
    :class:`optimize.service.chain.Refinement`) each chain then adds the wind speeds
    where its electrical power curve bends for the refinement's site. ``store``, ``backend``: see
    :class:`optimize.service.chain.ChainTask`; ``handle``, ``workers``,
    ``scheduler``, ``on_event``: see :func:`run_chains`.
    """
    groups: dict[tuple, list[SolveTask]] = {}
    for t in tasks:
        groups.setdefault((t.problem.key, t.kind, t.tag), []).append(t)
    chains = []
    for i, g in enumerate(groups.values()):
        winds = tuple(sorted({float(t.wind_speed_m_s) for t in g}))
        chains.append(ChainTask(g[0].problem, chain_steps((g[0].kind,), winds), i, g[0].tag,
                                store, backend, refine=refine(g[0].kind) if refine else None))
    outs, _ = run_chains(chains, handle, workers=workers, scheduler=scheduler, on_event=on_event)
    return [rec for out in outs for rec in out.records]


@dataclass(frozen=True)
class SweepResult:
    """All chains of a ``bench optimize`` sweep, gathered in the driver.

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

    def record(self) -> dict:
        """The sweep's part of the optimize manifest (docs/schemas.md §5): where it ran, how
        long, the scenarios that failed, each chain, the cut-in searches."""
        return {
            "executor": self.executor,
            "wall_time_s": self.wall_time_s,
            "failed": [o.name for o in self.outcomes if not o.success],
            "chains": [{"chain": c.chain, "worker": c.worker, "build_time_s": c.build_time_s,
                        "scenarios": [o.name for o in c.outcomes]} for c in self.chains],
            "cut_in": [dataclasses.asdict(c) for c in self.cut_ins],
        }


def make_tasks(chains: tuple[Chain, ...], problem: Problem, cut_in_kinds: tuple[str, ...] = (),
               cut_in_tol_m_s: float = 0.05, backend: Any = None) -> tuple[ChainTask, ...]:
    """The tasks of ``bench optimize``'s planned chains: local optima re-solved, each
    cut-in search in the chain that solved its kind."""
    return tuple(ChainTask(problem, c.steps, c.index, backend=backend, resolve=True,
                           cut_in_kinds=tuple(k for k in c.kinds if k in cut_in_kinds),
                           cut_in_tol_m_s=cut_in_tol_m_s)
                 for c in chains)


def run_sweep(tasks: tuple[ChainTask, ...], handle: Any,
              show_progress: bool = True) -> SweepResult:
    """Run ``bench optimize``'s chain tasks on an open executor and gather the outcomes.

    Parameters
    ----------
    tasks : tuple of ChainTask
        From :func:`make_tasks`.
    handle : optimize.service.executors.ExecutorHandle
        The open executor and its progress channel.
    show_progress : bool
        Show a tqdm bar: one tick per planned scenario, per cut-in search, per cut-in
        probe and per local-optimum re-solve (the last two added as they come), and
        beside it what the solver is running.

    Returns
    -------
    SweepResult
        A chain whose task raised is recorded with every scenario failed
        (:func:`failed_chain`); nothing is silently dropped.
    """
    from tqdm import tqdm

    total = sum(len(t.steps) + len(t.cut_in_kinds) for t in tasks)
    bar = tqdm(total=total, desc="optimize", unit="solve", disable=not show_progress)
    n_failed = 0

    def on_event(event: dict) -> None:
        nonlocal n_failed
        if "attempt" in event:  # every solver run says what it is; re-solves also count
            bar.set_postfix_str(attempt_line(event))
            if event["attempt"] == "done" and event["role"] == LOCAL_OPTIMUM:
                bar.total += 1
                bar.update(1)
            return
        if "cut_in" in event:
            bar.set_postfix_str(f"cut-in {event['cut_in']} done")
        elif event["role"] == "grid":
            n_failed += 0 if event["success"] else 1
            bar.set_postfix_str(f"{event['name']}: {event['status']}, failed {n_failed}")
        else:  # a cut-in probe: one more solve than planned
            bar.total += 1
        bar.update(1)

    t0 = time.perf_counter()
    chains, description = run_chains(tasks, handle, on_event=on_event)
    wall = time.perf_counter() - t0
    bar.update(bar.total - bar.n)  # the total grew by the probes and re-solves
    bar.close()
    order = {k: i for i, k in enumerate(dict.fromkeys(s.kind for t in tasks for s in t.steps))}
    outcomes = sorted((o for c in chains for o in c.outcomes),
                      key=lambda o: (order[o.kind], o.wind_speed_m_s))
    cut_ins = tuple(ci for c in chains for ci in c.cut_ins)
    return SweepResult(tuple(outcomes), cut_ins, tuple(chains), wall, description)


