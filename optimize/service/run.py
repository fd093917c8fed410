"""Run chains and start graphs on the local process pool or a Dask cluster; gather results.

* :func:`run_chains` submits each :class:`optimize.service.chain.ChainTask` as one
  executor task; a chain whose worker died reports every planned speed failed with
  status ``"worker error: <type>: <message>"`` (nothing is silently dropped);
* :func:`solve_tasks` solves a list of :class:`SolveTask` (``bench size``,
  ``bench aep --refine``): one chain per (problem, kind, tag), along the
  continuation order of its wind speeds; returns the solve records;
* :func:`run_sweep` runs ``bench optimize``'s start graph (:class:`SweepTasks`,
  :func:`optimize.service.plan.plan_graph`) with a progress bar: each step is one task,
  submitted once its sources are solved, with their optima as its warm starts; then
  one task per kind retries its failed scenarios from the other starts there are,
  re-solves its local optima and searches its cut-in speed; returns a
  :class:`SweepResult`. A Dask cluster lost on the way
  (:class:`optimize.service.executors.ClusterLost`) ends the sweep with what finished: the
  steps not run fail with status ``"not run: ..."``, the follow-up tasks not run leave
  their kind's grid as solved, and :attr:`SweepResult.lost` says why. So does a worker
  of the local pool that ended abruptly (a solver call that hung past its hard stop,
  :class:`optimize.service.executors.WorkerLost`), and a sweep that gave its solver up
  (:attr:`SweepTasks.give_up_after` scenarios failed and none converged, :class:`GaveUp`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from optimize.problem.scenario import Scenario
from optimize.service.builder import Problem
from optimize.service.chain import ChainTask, Refinement, run_chain
from optimize.service.executors import ClusterLost, WorkerLost
from optimize.service.foreign import ForeignStart
from optimize.service.local_optima import LOCAL_OPTIMUM
from optimize.service.outcome import (
    NOT_RUN,
    WORKER_ERROR,
    Attempt,
    ChainOutcome,
    CutIn,
    ScenarioOutcome,
    failure_status,
)
from optimize.service.period_scan import PERIOD_SCAN
from optimize.service.plan import Step, chain_steps
from optimize.service.retry import RETRY
from optimize.service.solves import attempt_line
from optimize.service.store import solve_key

#: the roles of the solver runs that add a tick to the progress bar as they come
RE_SOLVES = (LOCAL_OPTIMUM, PERIOD_SCAN, RETRY)


#: the status of a chain that was running when a worker of the local pool ended abruptly:
#: its own call, or one beside it, hung (the run's WORKER LOST line names the one that had
#: been going on longest, :class:`~optimize.service.executors.WorkerLost`)
POOL_BROKE = ("worker lost: the local pool broke while this ran (its solver call, or one "
              "running beside it, hung past its hard stop: see the run's WORKER LOST line)")


def failed_chain(task: ChainTask, exc: BaseException) -> ChainOutcome:
    """The outcome of a chain whose task raised (or never ran, ``exc`` the
    :class:`~optimize.service.executors.ClusterLost` that stopped it): every planned speed
    failed, with the one failure format (:func:`optimize.service.outcome.failure_status`;
    ``"not run: cluster lost: ..."`` for one never run, :data:`POOL_BROKE` for one running
    when the local pool broke); the scenarios handed to it as solved stay as they were."""
    status = (f"{NOT_RUN}: {exc.why}" if isinstance(exc, ClusterLost)
              else f"{WORKER_ERROR}: {POOL_BROKE}" if isinstance(exc, BrokenProcessPool)
              else failure_status(WORKER_ERROR, exc))
    outcomes = tuple(o for o, _ in task.solved) + tuple(
        ScenarioOutcome(s.scenario, task.index, (Attempt(
            None if s.warm_from is None else s.warm_from.name, status, False, 0, 0.0),), None)
        for s in task.steps)
    records = tuple(r for _, r in task.solved) + tuple({**dict(task.tag),
                     "key": (solve_key(task.problem, s.scenario)
                             if task.store is not None else None),
                     "kind": s.scenario.kind, "wind_speed_m_s": s.scenario.wind_speed_m_s,
                     "role": "grid", "success": False, "status": status, "cached": False}
                    for s in sorted(task.steps, key=lambda s: s.scenario.wind_speed_m_s))
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
    """One solve: a problem (system, drive model, options) and a scenario.

    ``tag`` (e.g. ``(("candidate", "x1"),)``) is copied into the record and progress events.
    """

    problem: Problem
    scenario: Scenario
    tag: tuple[tuple[str, Any], ...] = ()


def solve_tasks(tasks: Sequence[SolveTask], store: Path | None = None, *, workers: int = 2,
                scheduler: str | None = None, handle: Any = None, backend: Any = None,
                refine: Callable[[str], Refinement] | None = None,
                on_event: Callable[[dict], None] | None = None,
                reference: tuple[tuple[str, Any], ...] | None = None) -> list[dict]:
    """Solve every task; the records of each chain, sorted by wind speed, chain after chain.

    Tasks of one problem, kind and tag form one chain (one executor task), planned
    along the continuation order of their wind speeds
    (:func:`optimize.service.plan.chain_steps`). With ``refine`` (kind -> its
    :class:`optimize.service.chain.Refinement`) each chain then adds the wind speeds
    where its electrical power curve bends for the refinement's site.

    With ``reference`` (a tag, e.g. ``(("candidate", "x1"),)``) the chains of that tag
    run first, and every solve of the other chains starts from the reference's solution
    of the same kind and wind speed (:class:`optimize.service.foreign.ForeignStart`),
    before its own neighbours: one cold start in all, the reference's (``bench size``).

    ``store``, ``backend``: see :class:`optimize.service.chain.ChainTask`; ``handle``,
    ``workers``, ``scheduler``, ``on_event``: see :func:`run_chains`.
    """
    if handle is None:
        from optimize.service.executors import open_executor

        with open_executor(workers, scheduler) as h:
            return solve_tasks(tasks, store, handle=h, backend=backend, refine=refine,
                               on_event=on_event, reference=reference)
    groups: dict[tuple, list[SolveTask]] = {}
    for t in tasks:
        groups.setdefault((t.problem.key, t.scenario.kind, t.tag), []).append(t)
    chains = []
    for i, g in enumerate(groups.values()):
        kind = g[0].scenario.kind
        wind_speeds_m_s = tuple(sorted({t.scenario.wind_speed_m_s for t in g}))
        chains.append(ChainTask(g[0].problem, chain_steps((kind,), wind_speeds_m_s), i,
                                g[0].tag, store, backend,
                                refine=refine(kind) if refine else None))
    first = [c for c in chains if reference is not None and c.tag == tuple(reference)]
    rest = [c for c in chains if reference is None or c.tag != tuple(reference)]
    outs = dict(zip((c.index for c in first), run_chains(first, handle, on_event=on_event)[0],
                    strict=True))
    if first:
        starts = tuple(f for c in first for f in reference_starts(c, outs[c.index]))
        rest = [dataclasses.replace(c, foreign=starts) for c in rest]
    outs.update(zip((c.index for c in rest), run_chains(rest, handle, on_event=on_event)[0],
                    strict=True))
    return [rec for i in sorted(outs) for rec in outs[i].records]


def reference_starts(task: ChainTask, out: ChainOutcome) -> tuple[ForeignStart, ...]:
    """The converged solves of a finished chain, as starts of other problems' solves
    (:class:`optimize.service.foreign.ForeignStart`, labelled with the chain's tag values):
    the solutions it solved, and those it loaded from the store."""
    from optimize.service.store import load_solve

    label = " ".join(str(v) for _, v in task.tag) or "reference"
    solved = {o.scenario: o for o in out.outcomes if o.success and o.result is not None}
    starts = []
    for rec in out.records:
        if not rec["success"]:
            continue
        scenario = Scenario.of_kind(rec["kind"], rec["wind_speed_m_s"])  # the stored form
        if scenario in solved:
            warm, depth = solved[scenario].result.warm, solved[scenario].depth
        else:  # loaded from the store (or solved after the planned steps): its stored warm start
            stored = load_solve(task.store, rec["key"]) if rec.get("key") else None
            warm, depth = (None, 0) if stored is None else (stored[1], 0)
        if warm is not None:
            starts.append(ForeignStart(scenario, label, depth, problem=task.problem, warm=warm))
    return tuple(starts)


@dataclass(frozen=True)
class SweepResult:
    """A ``bench optimize`` sweep, gathered in the driver.

    Attributes
    ----------
    outcomes : tuple of ScenarioOutcome
        One per scenario, sorted by kind (as selected) then wind speed.
    cut_ins : tuple of CutIn
    chains : tuple of ChainOutcome
        Per task (one per step of the start graph, then one per kind for its re-solves
        and cut-in search): worker, NLP build time, its scenarios.
    wall_time_s : float
        Wall time of the whole sweep, cold starts included [s].
    executor : str
        Description of the executor it ran on.
    lost : str or None
        Why the sweep ended before its end: its Dask cluster was lost
        (:class:`optimize.service.executors.ClusterLost`), a worker of the local pool
        ended abruptly (:class:`optimize.service.executors.WorkerLost`: a solver call that
        hung), or it gave up on its solver (:class:`GaveUp`); None when it ran to its end.
    stopped : str
        The label of a loss the run decided itself (``"WORKER LOST"``, ``"STOPPED"``:
        a re-run may meet it again), ``""`` for none or a lost cluster.
    """

    outcomes: tuple[ScenarioOutcome, ...]
    cut_ins: tuple[CutIn, ...]
    chains: tuple[ChainOutcome, ...]
    wall_time_s: float
    executor: str
    lost: str | None = None
    stopped: str = ""

    def iterations(self) -> dict[str, int]:
        """What the sweep's solves cost in solver iterations: ``reported`` (the final
        solve of each scenario, the summary's ``iterations``), ``intermediate_points`` and
        ``intermediate_iterations`` (on the way to those final solves,
        :mod:`optimize.solve.starts.continuation`), ``all`` (every solver run of the
        sweep: failed attempts, retries, re-solves, the period scan and the cut-in
        probes, with their ways) and ``by_role``: ``all`` by why the runs ran."""
        finals = [o.attempts[-1] for o in self.outcomes if o.attempts]
        roles: dict[str, int] = {}
        for c in self.chains:
            for role, n in c.iterations.items():
                roles[role] = roles.get(role, 0) + n
        return {"reported": sum(a.iterations for a in finals),
                "intermediate_points": sum(a.intermediate_points for a in finals),
                "intermediate_iterations": sum(a.intermediate_iterations for a in finals),
                "all": sum(roles.values()), "by_role": roles}

    def record(self) -> dict:
        """The sweep's part of the optimize manifest (docs/schemas.md §5): where it ran, how
        long, the scenarios that failed, each task, each worker's setup (the time it spent
        building the NLP before its first solve, paid once per worker process), the
        cut-in searches."""
        workers: dict[str, list] = {}
        for c in self.chains:
            workers.setdefault(c.worker, []).append(c.build_time_s)
        return {
            "executor": self.executor,
            "wall_time_s": self.wall_time_s,
            "iterations": self.iterations(),
            "failed": [o.name for o in self.outcomes if not o.success],
            "chains": [{"chain": c.chain, "worker": c.worker, "build_time_s": c.build_time_s,
                        "scenarios": [o.name for o in c.outcomes]} for c in self.chains],
            "workers": [{"worker": w, "build_time_s": sum(b), "tasks": len(b)}
                        for w, b in workers.items()],
            "cut_in": [dataclasses.asdict(c) for c in self.cut_ins],
            "cluster_lost": self.lost,
        }


@dataclass(frozen=True)
class SweepTasks:
    """``bench optimize``'s sweep as the service runs it (:func:`run_sweep`).

    Attributes
    ----------
    problem : Problem
    steps : tuple of Step
        The start graph (:func:`optimize.service.plan.plan_graph`), sources first.
    cut_in_kinds : tuple of str
        Kinds whose cut-in speed is searched after the grid.
    cut_in_tol_m_s : float
        Bisection stops when the bracket is at most this wide [m/s].
    backend : optional
        The numerical side (:class:`optimize.service.builder.OcpBackend` by default).
    period_scan : int
        Held periods per converged scenario of the period scan (0: none;
        :mod:`optimize.service.period_scan`).
    selected : tuple of str
        The scenario kinds as selected, the order of the outcomes; empty: in the order
        of the steps.
    give_up_after : int
        Give the sweep up once this many of its scenarios failed and none converged
        (:class:`GaveUp`; 0: never): ``bench optimize`` with a solver other than the
        default, which has one to name instead.
    """

    problem: Problem
    steps: tuple[Step, ...]
    cut_in_kinds: tuple[str, ...] = ()
    cut_in_tol_m_s: float = 0.05
    backend: Any = None
    period_scan: int = 0
    selected: tuple[str, ...] = ()
    give_up_after: int = 0

    @property
    def kinds(self) -> tuple[str, ...]:
        """The scenario kinds, as selected (else in the order of the steps)."""
        return self.selected or tuple(dict.fromkeys(s.scenario.kind for s in self.steps))


class GaveUp(ClusterLost):
    """The sweep gave its solver up: ``n`` of its scenarios failed and none converged
    (:attr:`SweepTasks.give_up_after`). The tasks running then finish; the rest are not
    run, as after a lost cluster (what finished is kept)."""

    label = "STOPPED"

    def __init__(self, n: int) -> None:
        super().__init__(
            f"gave up: {n} scenarios failed and none converged",
            f"{n} scenarios failed and none converged: the sweep gives its solver up there, "
            "nothing more is solved: what finished is kept",
            expected="a solver that converges some of the scenarios")


def _own(out: ChainOutcome, step: Step) -> ChainOutcome:
    """A step task's outcome with only its own scenario (not the starts handed to it)."""
    own = step.scenario
    return dataclasses.replace(
        out, outcomes=tuple(o for o in out.outcomes if o.scenario == own),
        records=tuple(r for r in out.records
                      if (r["kind"], r["wind_speed_m_s"]) == (own.kind, own.wind_speed_m_s)))


def _solve_graph(tasks: SweepTasks, stage: int, prior: dict[Scenario, tuple], handle: Any,
                 on_event: Callable[[dict], None]
                 ) -> tuple[dict[int, ChainOutcome], ClusterLost | None]:
    """Solve every step of one stage of the start graph, each as one task once its
    sources are done, the scenarios of ``prior`` (scenario -> (outcome, record), the
    earlier stages' results) among its warm starts; one outcome per step, by its index
    in ``tasks.steps``, and the loss of the cluster that ended it early (the steps it did
    not finish failed ``"not run"``), or None."""
    from optimize.service.executors import run_graph

    at = [i for i, s in enumerate(tasks.steps) if s.stage == stage]
    steps = [tasks.steps[i] for i in at]
    index = {s.scenario: n for n, s in enumerate(steps)}
    outs: dict[int, ChainOutcome] = {}
    made: dict[int, ChainTask] = {}

    def needs(n: int) -> list[int]:
        return [index[m] for m in (steps[n].warm_from, *steps[n].fallbacks) if m in index]

    def outcome(j: int, future: Any) -> ChainOutcome:
        if j not in outs:
            exc = future.exception()
            outs[j] = _own(failed_chain(made[j], exc) if exc is not None else future.result(),
                           steps[j])
        return outs[j]

    def make_task(n: int, done: dict) -> ChainTask:
        solved = tuple((o, r) for j in needs(n)
                       for o, r in zip(outcome(j, done[j]).outcomes, outcome(j, done[j]).records,
                                       strict=True) if o.success)
        earlier = tuple(prior[m] for m in (steps[n].warm_from, *steps[n].fallbacks)
                        if m in prior and prior[m][0].success)
        made[n] = ChainTask(tasks.problem, (steps[n],), at[n], backend=tasks.backend,
                            solved=(*earlier, *solved))
        return made[n]

    def give_up(done: dict) -> GaveUp | None:
        if not tasks.give_up_after or any(o.success for o, _ in prior.values()):
            return None
        own = [o for j in done for o in outcome(j, done[j]).outcomes]
        if any(o.success for o in own) or len(own) < tasks.give_up_after:
            return None
        return GaveUp(len(own))

    lost = None
    try:
        futures = run_graph(handle.executor, run_chain, len(steps), needs, make_task,
                            handle.channel, on_event, stop=give_up)
    except ClusterLost as exc:
        futures, lost = exc.finished, exc
    return {at[n]: outcome(n, futures[n]) if n in futures else _never_ran(tasks, at[n], lost)
            for n in range(len(steps))}, lost


def _follow_up(tasks: SweepTasks, stage: int, solved: list[tuple],
               handle: Any, on_event: Callable[[dict], None], lost: ClusterLost | None
               ) -> tuple[list[ChainOutcome], ClusterLost | None]:
    """Per kind of the ``stage``, one task: its failed scenarios retried from the other
    starts (the other kinds' optima at their speeds), its local optima re-solved (on
    their power alone after stage 0), its periods scanned (when asked), its cut-in speed
    searched. ``solved``: every (outcome, record) solved so far. With the cluster
    ``lost`` (before or during them) a task not run leaves its kind's grid as solved."""
    from optimize.service.executors import run_tasks

    failed = [o.scenario for o, _ in solved if not o.success]

    def starts(kind: str) -> tuple:
        wind_speeds_m_s = {s.wind_speed_m_s for s in failed if s.kind == kind}
        return tuple((o, r) for o, r in solved if o.success and o.wind_speed_m_s in wind_speeds_m_s
                     and o.kind != kind)

    follow = [ChainTask(tasks.problem, (), len(tasks.steps) + tasks.kinds.index(kind),
                        backend=tasks.backend, resolve=True, resolve_by_period=stage == 0,
                        period_scan=tasks.period_scan,
                        cut_in_kinds=(kind,) if kind in tasks.cut_in_kinds else (),
                        cut_in_tol_m_s=tasks.cut_in_tol_m_s,
                        solved=tuple((o, r) for o, r in solved if o.kind == kind),
                        starts=starts(kind), retry=True)
              for kind in dict.fromkeys(s.scenario.kind for s in tasks.steps if s.stage == stage)]
    finished: dict = {}
    if lost is None:
        try:
            finished = dict(enumerate(run_tasks(handle.executor, run_chain, follow,
                                                handle.channel, on_event)))
        except ClusterLost as exc:
            finished, lost = exc.finished, exc
    return [failed_chain(t, lost) if n not in finished else
            failed_chain(t, finished[n].exception()) if finished[n].exception() is not None
            else finished[n].result() for n, t in enumerate(follow)], lost


def _run_stages(tasks: SweepTasks, handle: Any, on_event: Callable[[dict], None]
                ) -> tuple[list[ChainOutcome], list[ChainOutcome], ClusterLost | None]:
    """Each stage of the start graph, then its kinds' follow-up tasks, the later stages
    starting from the earlier ones' final optima (:func:`optimize.service.plan.plan_graph`):
    the step tasks' outcomes in step order, the follow-up tasks' and the cluster loss."""
    grid: dict[int, ChainOutcome] = {}
    follow: list[ChainOutcome] = []
    lost = None
    final: list[tuple] = []  # (outcome, record) of every kind followed up so far
    for stage in sorted({s.stage for s in tasks.steps}):
        prior = {o.scenario: (o, r) for o, r in final}
        outs, lost = (_solve_graph(tasks, stage, prior, handle, on_event) if lost is None
                      else _not_run(tasks, stage, lost))
        grid.update(outs)
        solved = [(o, r) for out in outs.values()
                  for o, r in zip(out.outcomes, out.records, strict=True)]
        done, lost = _follow_up(tasks, stage, [*final, *solved], handle, on_event, lost)
        follow += done
        final += [_with_record(c, o) for c in done for o in c.outcomes]
    return [grid[i] for i in sorted(grid)], follow, lost


def _with_record(out: ChainOutcome, o: ScenarioOutcome) -> tuple[ScenarioOutcome, dict]:
    """A scenario of a follow-up task's outcome with its record (the task's records also
    hold its cut-in probes and added speeds)."""
    return o, next(r for r in out.records
                   if (r["kind"], r["wind_speed_m_s"]) == (o.kind, o.wind_speed_m_s))


def _not_run(tasks: SweepTasks, stage: int, lost: ClusterLost) -> tuple[dict, ClusterLost]:
    """The steps of a stage that never ran: the cluster was lost before it."""
    return {i: _never_ran(tasks, i, lost)
            for i, s in enumerate(tasks.steps) if s.stage == stage}, lost


def _never_ran(tasks: SweepTasks, i: int, lost: ClusterLost) -> ChainOutcome:
    """The outcome of step ``i``, never run: the cluster was lost before it."""
    step = tasks.steps[i]
    return _own(failed_chain(ChainTask(tasks.problem, (step,), i), lost), step)


def run_sweep(tasks: SweepTasks, handle: Any, show_progress: bool = True) -> SweepResult:
    """Run ``bench optimize``'s sweep on an open executor and gather the outcomes.

    Parameters
    ----------
    tasks : SweepTasks
        The start graph and what follows it per kind.
    handle : optimize.service.executors.ExecutorHandle
        The open executor and its progress channel.
    show_progress : bool
        Show a tqdm bar: one tick per planned scenario, per cut-in search, per cut-in
        probe, per retry, per local-optimum re-solve and per period-scan run (the last
        four added as they come), and beside it what the solver is running.

    Returns
    -------
    SweepResult
        A task that raised is recorded with its scenario failed (:func:`failed_chain`);
        nothing is silently dropped.
    """
    from tqdm import tqdm

    bar = tqdm(total=len(tasks.steps) + len(tasks.cut_in_kinds), desc="optimize",
               unit="solve", disable=not show_progress)
    n_failed = 0
    running: dict[int, tuple[str, float]] = {}  # chain -> its solver run now, since when

    def on_event(event: dict) -> None:
        nonlocal n_failed
        if "attempt" in event:  # every solver run says what it is; re-solves also count
            bar.set_postfix_str(attempt_line(event))
            running[event["chain"]] = (attempt_line(event), time.monotonic())
            if event["attempt"] == "done":
                del running[event["chain"]]
            if event["attempt"] == "done" and event["role"] in RE_SOLVES:
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
    grid, follow, lost = _run_stages(tasks, handle, on_event)
    wall, t_end = time.perf_counter() - t0, time.monotonic()
    bar.update(bar.total - bar.n)  # the total grew by the probes and re-solves
    bar.close()
    order = {k: i for i, k in enumerate(tasks.kinds)}
    outcomes = sorted((o for c in follow for o in c.outcomes),
                      key=lambda o: (order[o.kind], o.wind_speed_m_s))
    cut_ins = tuple(ci for c in follow for ci in c.cut_ins)
    why = None if lost is None else lost.problem
    if isinstance(lost, WorkerLost) and running:  # the run that had gone on longest
        line, since = min(running.values(), key=lambda r: r[1])
        why += (f"; the solver run going on longest then: {line.removesuffix(' ...')} for "
                f"{t_end - since:.0f} s")
    stopped = "" if lost is None or lost.label == ClusterLost.label else lost.label
    return SweepResult(tuple(outcomes), cut_ins, (*grid, *follow), wall, handle.description,
                       why, stopped)
