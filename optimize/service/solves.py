"""The solves of one problem on one worker: warm starts, fallbacks, records, the store.

A :class:`Solves` holds one problem (system, drive model, OCP options) on one
worker. It builds the NLP once (cached per process) and solves each scenario:

* warm-started from the given sources in order (scenarios solved earlier here, of
  any kind; at most :data:`MAX_WARM_ATTEMPTS` of those that converged),
  by default from the nearest converged speed of the same kind; then, when none
  converged, a cold start (the stored initial guess or the homotopy);
* a solver crash is a failed attempt of that speed (status
  ``"exception: <type>: <message>"``, :func:`optimize.service.outcome.failure_status`),
  never a failed sweep;
* a scenario's solver runs here and in earlier tasks (its outcome's attempts and
  re-solves), all together, take at most :attr:`Problem.scenario_budget_s`
  (:data:`~optimize.problem.deadline.SCENARIO_CALLS` call limits): each runs within what is
  left of it (:func:`~optimize.problem.deadline.deadline`), and none starts once it is
  spent (the run fails at once with the status :func:`spent_status`);
* with a store, each finished solve is kept under the hash of its inputs
  (:func:`optimize.service.store.solve_key`) and a re-run loads it instead of
  solving it, once its files pass their checks (:func:`optimize.service.store.read_solve`);
  one that does not is solved again, its record's ``store_rejected`` naming the file and
  why; a crash is not stored (it may be transient: a re-run tries again).

Each solve gives a :class:`optimize.service.outcome.ScenarioOutcome` (attempts,
the backend's result; kept in memory) and a record (a flat dict of its figures,
the stored form).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from optimize.problem.deadline import SCENARIO_CALLS, WALL_STATUS, deadline
from optimize.problem.scenario import Scenario
from optimize.service.builder import Backend, OcpBackend, Problem
from optimize.service.foreign import Start
from optimize.service.outcome import CRASH, Attempt, ScenarioOutcome, failure_status
from optimize.service.store import read_solve, solve_key, store_solve
from optimize.solve.result import cycle_metrics

#: warm-started attempts per solve before the cold-start fallback
MAX_WARM_ATTEMPTS = 2
#: the cycle figures of a record, None when the solve failed (:func:`cycle_metrics`); the
#: parts' own figures follow when it converged (``OcpResult.figures``)
METRICS = ("peak_speed_rpm", "peak_torque_nm", "rms_torque_nm")


def spent_status(budget_s: float) -> str:
    """The status of a solver run not started: its scenario's ``budget_s`` [s] was spent."""
    return (f"{WALL_STATUS}: not run, the scenario's {budget_s:g} s were spent (its solver "
            f"runs take at most {SCENARIO_CALLS} times --call-time-limit in all)")


def _figure(result: Any, name: str) -> float | None:
    value = getattr(result, name, None)
    return None if value is None else float(value)


class Solves:
    """The solves of one problem on one worker (see the module docstring).

    Parameters
    ----------
    problem : Problem
        System, drive model and OCP options.
    store : Path or None
        Folder of the stored solves; None stores nothing.
    backend : optional
        The numerical side (:class:`optimize.service.builder.OcpBackend` by default).
    progress : object with ``put(dict)``, optional
        Receives, after each solve, ``{tag..., "chain", "name", "kind", "wind_speed_m_s", "role",
        "success", "status", "cached", "wall_time_s"}``; and around each solver run
        (:meth:`attempt`) ``{tag..., "attempt": "start" or "done", "chain", "name", "role",
        "from", "status"}``, so a bar can say what runs (:func:`attempt_line`).
    tag : dict, optional
        Fields added to every record and progress event (e.g. the candidate's name).
    extras : callable, optional
        ``extras(trajectory) -> dict`` of further figures of a converged cycle,
        added to its record (``extras(None)``'s keys with None values when it failed).
    chain : int
        Index of the chain these solves belong to, recorded in outcomes and events.
    """

    def __init__(self, problem: Problem, store: Path | None = None,
                 backend: Backend | None = None,
                 progress: Any = None, tag: dict | None = None,
                 extras: Callable[[Any], dict] | None = None, chain: int = 0) -> None:
        self.problem = problem
        self.store = store
        self.backend: Backend = backend or OcpBackend()
        self.progress = progress
        self.tag = dict(tag or {})
        self.extras = extras
        self.chain = chain
        self.records: dict[Scenario, dict] = {}
        self.outcomes: dict[Scenario, ScenarioOutcome] = {}
        self.build_time_s = 0.0
        #: every NLP solver iteration run here, by role (:meth:`count`)
        self.iterations: dict[str, int] = {}
        #: starts from other problems' solutions, tried first (:mod:`optimize.service.foreign`)
        self.foreign: dict[Scenario, Start] = {}
        self._warm: dict[Scenario, Any] = {}
        self._depth: dict[Scenario, int] = {}
        self._ocp = None
        #: wall time of each scenario's solver runs so far [s], those of earlier tasks too
        self.spent_s: dict[Scenario, float] = {}

    @property
    def ocp(self) -> Any:
        """The built NLP (built on first use; :attr:`build_time_s` says how long it took)."""
        if self._ocp is None:
            t0 = time.perf_counter()
            self._ocp = self.backend.build(self.problem)
            self.build_time_s = time.perf_counter() - t0
        return self._ocp

    def converged(self, kind: str) -> list[Scenario]:
        """The scenarios of ``kind`` with a converged solution to warm-start from, by wind
        speed."""
        return sorted((s for s in self._warm if s.kind == kind), key=lambda s: s.wind_speed_m_s)

    def nearest(self, scenario: Scenario) -> list[Scenario]:
        """The converged scenarios of ``scenario``'s kind (:meth:`converged`), the nearest
        wind speed first (the lower one at equal distance)."""
        return sorted(self.converged(scenario.kind),
                      key=lambda s: abs(s.wind_speed_m_s - scenario.wind_speed_m_s))

    def attempt(self, scenario: Scenario, source: Scenario | Start | None,
                role: str = "grid", period_s: float | None = None) -> tuple[Attempt, Any]:
        """One solver run of ``scenario`` from the converged ``source`` (None: a cold
        start; a :class:`optimize.service.foreign.Start`: one it did not find itself,
        another problem's solution or a stored cycle) for ``role`` (why it runs, for the
        progress events), with the period held at ``period_s`` [s] when given (a warm
        start only), within what is left of the scenario's budget (not run when nothing
        is: :func:`spent_status`); a crash is a failed attempt with no result."""
        ocp = self.ocp
        name = None if source is None else source.name
        self.tell("start", scenario.name, role, name, "")
        with self.budget(scenario) as left_s:
            attempt, result = (self._run(ocp, scenario, source, period_s, left_s) if left_s > 0
                               else (Attempt(name, spent_status(self.problem.scenario_budget_s),
                                             False, 0, 0.0), None))
        self.count(attempt, role)
        self.tell("done", scenario.name, role, name, attempt.status)
        return attempt, result

    @contextmanager
    def budget(self, scenario: Scenario) -> Iterator[float]:
        """While open, a solver run of ``scenario`` goes on, its time counted in
        :attr:`spent_s`; yields what is left of its budget [s]
        (:attr:`Problem.scenario_budget_s`; when nothing is, run nothing; else the run's
        solver calls go on within it, :func:`deadline`)."""
        t0 = time.perf_counter()
        try:
            yield self.problem.scenario_budget_s - self.spent_s.get(scenario, 0.0)
        finally:
            self.spent_s[scenario] = self.spent_s.get(scenario, 0.0) + time.perf_counter() - t0

    def _run(self, ocp: Any, scenario: Scenario, source: Scenario | Start | None,
             period_s: float | None, left_s: float) -> tuple[Attempt, Any]:
        """:meth:`attempt`'s solver run, its calls within ``left_s`` [s], and its check."""
        given = isinstance(source, Start)
        name = None if source is None else source.name
        t0 = time.perf_counter()
        try:
            with deadline(left_s):
                if source is None:
                    result = self.backend.cold_start(ocp, scenario)
                else:
                    warm = source.carried(self.backend, ocp) if given else self._warm[source]
                    held = {} if period_s is None else {"period_s": period_s}
                    result = self.backend.solve(ocp, scenario, warm, **held)
        except Exception as exc:  # noqa: BLE001 - a crash is this speed's failure, reported
            attempt, result = Attempt(name, failure_status(CRASH, exc), False, 0,
                                      time.perf_counter() - t0), None
        else:
            ok = bool(result.success) and math.isfinite(float(result.avg_p_elec_w))
            check = self.backend.check(ocp, result, scenario.name) if ok else None
            passed = ok and (check is None or check.passed)
            attempt = Attempt(name, str(result.status), passed, int(result.iterations),
                              float(result.wall_time_s), check,
                              int(getattr(result, "intermediate_points", 0)),
                              int(getattr(result, "intermediate_iterations", 0)))
        return attempt, result

    def count(self, attempt: Attempt, role: str) -> None:
        """Add a solver run's iterations, its way included, to :attr:`iterations` of
        ``role`` (why it ran)."""
        self.iterations[role] = self.iterations.get(role, 0) + attempt.all_iterations

    def tell(self, when: str, name: str, role: str, source: str | None,
             status: str) -> None:
        """Say a solver run of the scenario ``name`` starts (``when="start"``) or is done,
        to the progress channel (see the class docstring)."""
        if self.progress is not None:
            self.progress.put({**self.tag, "attempt": when, "chain": self.chain,
                               "name": name, "role": role,
                               "from": source, "status": status})

    def solve(self, scenario: Scenario, role: str = "grid",
              sources: Sequence[Scenario | Start] | None = None, cold: bool = True) -> dict:
        """The record of ``scenario``: loaded, solved earlier, or solved now.

        Parameters
        ----------
        scenario : Scenario
        role : str
            Why it is solved (``"grid"``, ``"added"``, ``"check"``, ``"cut-in"``), recorded.
        sources : sequence of Scenario or Start, optional
            Warm sources in order of preference; those not converged are skipped and at
            most :data:`MAX_WARM_ATTEMPTS` are tried. Default: the nearest converged
            speed of its kind. A start from another problem's solution of this scenario
            (:attr:`foreign`) is tried before them.
        cold : bool
            Fall back to a cold start when no warm start converged.

        Returns
        -------
        dict
            Keys: the tag's, ``key`` (of the store, None without one), ``kind,
            wind_speed_m_s, role, success, status, warm_from, avg_p_elec_w, avg_p_mech_w,
            period_s, peak_speed_rpm, peak_torque_nm, rms_torque_nm`` (None when
            failed), the parts' figures (``OcpResult.figures``, when converged), the
            extras,
            ``wall_time_s, cached``, and ``store_rejected`` when its stored files were not
            believed (the file and why; solved again).
        """
        if scenario in self.records:
            return self.records[scenario]
        key = solve_key(self.problem, scenario) if self.store is not None else None
        stored = read_solve(self.store, key, scenario) if key is not None else None
        if stored is not None and stored.record is not None:
            rec, warm = stored.record, stored.warm
            rec = {**rec, **self.tag, "role": role, "cached": True}
        else:
            if sources is None:
                sources = self.nearest(scenario)[:1]
            tried = [s for s in sources
                     if isinstance(s, Start) or s in self._warm][:MAX_WARM_ATTEMPTS]
            if scenario in self.foreign:
                tried.insert(0, self.foreign[scenario])
            attempts, result, src = [], None, None
            for src in tried:
                attempt, result = self.attempt(scenario, src, role)
                attempts.append(attempt)
                if attempt.success:
                    break
            if cold and not (attempts and attempts[-1].success):
                src = None
                attempt, result = self.attempt(scenario, None, role)
                attempts.append(attempt)
            outcome = ScenarioOutcome(scenario, self.chain, tuple(attempts), result,
                                      depth=self._depth_from(src))
            self.outcomes[scenario] = outcome
            rec = self.record(key, outcome, role, src)
            warm = result.warm if outcome.success else None
            if key is not None and result is not None:  # a crash is not stored
                store_solve(self.store, key, rec, warm)
            rec = {**rec, "cached": False}
            if stored is not None:  # its stored files were not believed: say which and why
                rec["store_rejected"] = stored.rejected
        self.records[scenario] = rec
        if rec["success"] and warm is not None:
            self._warm[scenario] = warm
            self._depth[scenario] = self.outcomes[scenario].depth if not rec["cached"] else 0
        if self.progress is not None:
            self.progress.put({**self.tag, "chain": self.chain, "name": scenario.name,
                               "kind": scenario.kind, "wind_speed_m_s": scenario.wind_speed_m_s,
                               "role": role, "success": rec["success"], "status": rec["status"],
                               "cached": rec["cached"], "wall_time_s": rec["wall_time_s"]})
        return rec

    def adopt(self, outcome: ScenarioOutcome, record: dict) -> None:
        """Take in a scenario another worker solved: its outcome and record, and its
        optimum as a warm start when it converged."""
        k = outcome.scenario
        self.outcomes[k], self.records[k] = outcome, record
        self.spent_s[k] = outcome.total_wall_time_s
        if outcome.success and outcome.result is not None:
            self._warm[k], self._depth[k] = outcome.result.warm, outcome.depth

    def _depth_from(self, source: Scenario | Start | None) -> int:
        """The start-graph depth of a solve started from ``source`` (None: cold, 0)."""
        if isinstance(source, Start):
            return source.depth + 1
        return 0 if source is None else self._depth.get(source, 0) + 1

    def replace(self, outcome: ScenarioOutcome, source: Scenario | Start) -> None:
        """Make ``outcome`` (a new result of a solved scenario, its last attempt started
        from ``source``) its result: its record and, when it succeeded (a better optimum,
        a failure retried), its warm start and its stored solve."""
        k = outcome.scenario
        key = self.records[k]["key"]
        outcome = dataclasses.replace(outcome, depth=self._depth_from(source))
        self.outcomes[k] = outcome
        rec = self.record(key, outcome, self.records[k]["role"], source)
        if outcome.success:
            if key is not None:
                store_solve(self.store, key, rec, outcome.result.warm)
            self._warm[k], self._depth[k] = outcome.result.warm, outcome.depth
        self.records[k] = {**rec, "cached": False}

    def replace_remeshed(self, outcome: ScenarioOutcome) -> None:
        """Make ``outcome`` (its last attempt solved on a finer mesh,
        :func:`optimize.service.retry.retry_on_finer_mesh`) its result: its record, and
        its stored solve without a warm start (another mesh's solution starts no solve
        of these)."""
        k = outcome.scenario
        key = self.records[k]["key"]
        self.outcomes[k] = outcome
        rec = self.record(key, outcome, self.records[k]["role"], None)
        if outcome.success and key is not None:
            store_solve(self.store, key, rec, None)
        self.records[k] = {**rec, "cached": False}

    def record(self, key: str | None, outcome: ScenarioOutcome, role: str,
               source: Scenario | Start | None) -> dict:
        """The flat record of an outcome whose final attempt started from ``source`` (see
        :meth:`solve`; the stored form)."""
        res, ok = outcome.result, outcome.success
        if source is None:
            warm_from = getattr(res, "start", "cold start")
        elif isinstance(source, Start):
            warm_from = source.warm_from(outcome.kind)
        elif source.kind == outcome.kind:
            warm_from = f"{source.wind_speed_m_s:g} m/s"
        else:
            warm_from = source.name
        trajectory = getattr(res, "trajectory", None) if ok else None
        metrics = dict.fromkeys(METRICS)
        if trajectory is not None:
            figures = cycle_metrics(trajectory)
            metrics = {name: figures[name] for name in METRICS}
            metrics.update(getattr(res, "figures", {}))
        extras = {}
        if self.extras is not None:
            extras = self.extras(trajectory) if ok else dict.fromkeys(self.extras(None))
        return {
            **self.tag, "key": key, "kind": outcome.kind, "wind_speed_m_s": outcome.wind_speed_m_s,
            "role": role, "success": ok, "status": outcome.status, "warm_from": warm_from,
            "avg_p_elec_w": _figure(res, "avg_p_elec_w") if ok else None,
            "avg_p_mech_w": _figure(res, "avg_p_mech_w") if ok else None,
            "period_s": _figure(res, "period_s") if ok else None,
            "result_check": outcome.check,
            **metrics, **extras,
            "wall_time_s": outcome.total_wall_time_s,
        }


def attempt_line(event: dict) -> str:
    """What a solver run of a progress event (:meth:`Solves.attempt`) is doing, in a few
    words: ``"local optimum: elec-lim-7.0 from elec-lim-8.5"``."""
    start = f"from {event['from']}" if event["from"] else "cold start"
    tail = "..." if event["attempt"] == "start" else event["status"]
    return f"{event['role']}: {event['name']} {start} {tail}"
