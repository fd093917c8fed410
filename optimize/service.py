"""One solve service: optimal cycles of (system, drive, wind, kind) tasks.

Every stage that solves the OCP at wind speeds of its choosing goes through
here (``bench size``, ``bench aep --refine``):

* a :class:`Solver` holds one problem (system, drive model, OCP options) on one
  worker: it builds the NLP once (cached per process), solves each (kind, wind)
  warm-started from the nearest converged speed of the same kind (a cold start
  from the stored guess or the homotopy when there is none or that fails), and
  stores each finished solve under the hash of its inputs (:func:`solve_key`),
  so a re-run loads it instead of solving: an interrupted sweep resumes;
* a solver crash is a failed solve of that speed, never a failed sweep: the
  record's ``status`` is ``"exception: <type>: <message>"`` and it is not
  stored (a crash may be transient, a re-run tries again);
* :func:`solve_tasks` solves a list of :class:`SolveTask` on the local process
  pool or a Dask cluster, one chain per (problem, kind) along
  :func:`optimize.sweep.plan.continuation_order`;
* the figures of a cycle (peaks, RMS torque) come from :func:`cycle_metrics`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bench.files import atomic_write, write_json
from optimize.kinds import KINDS
from optimize.sweep.chains import OcpBackend, Problem
from optimize.sweep.plan import continuation_order

#: bump when the meaning of a stored solve changes (invalidates every stored solve)
STORE_VERSION = 1


def solve_key(problem: Problem, kind: str, wind_m_s: float) -> str:
    """SHA-256 (hex) of everything one solve depends on: the drive model's hash, the OCP
    options, the wind speed, the kind's objective and limits, the system's hash (when
    the problem has a system)."""
    objective, limits = KINDS[kind]
    data = {"version": STORE_VERSION, "model": problem.drive_model.sha256,
            "options": dataclasses.asdict(problem.options), "wind_m_s": float(wind_m_s),
            "objective": objective, "drive_limits": bool(limits)}
    if problem.system is not None:
        data["system"] = problem.system.sha256
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def cycle_metrics(trajectory: Any) -> dict[str, float]:
    """Peak |speed| [rpm], peak torque [N m] and RMS torque [N m] of one cycle.

    ``trajectory`` has ``speed_rpm``, ``torque_nm`` and the quadrature ``weight``
    (summing to 1 over the cycle), as :attr:`optimize.solve.result.OcpResult.trajectory`.
    """
    speed = np.asarray(trajectory["speed_rpm"], dtype=float)
    torque = np.asarray(trajectory["torque_nm"], dtype=float)
    weight = np.asarray(trajectory["weight"], dtype=float)
    return {"peak_speed_rpm": float(np.max(np.abs(speed))),
            "peak_torque_nm": float(np.max(torque)),
            "rms_torque_nm": float(np.sqrt(np.sum(weight * torque**2)))}


def load_solve(store: Path, key: str) -> tuple[dict, Any] | None:
    """A stored solve (its record, its warm start or None) or None when absent or unreadable."""
    from optimize.solve.result import Solution

    js, npz = store / f"{key}.json", store / f"{key}.npz"
    if not js.is_file():
        return None
    try:
        rec = json.loads(js.read_text(encoding="utf-8"))
        warm = None
        if npz.is_file():
            with np.load(npz) as f:
                warm = Solution(f["w"], f["lam_x"], f["lam_g"], int(f["n_intervals"]),
                                int(f["degree"]))
    except (OSError, ValueError, KeyError):
        return None
    return rec, warm


def store_solve(store: Path, key: str, rec: dict, warm: Any) -> None:
    """Store a finished solve: the warm start first (a record without it is still usable),
    then the record, each written whole."""
    store.mkdir(parents=True, exist_ok=True)
    if warm is not None:
        def write_npz(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                np.savez(fh, w=warm.w, lam_x=warm.lam_x, lam_g=warm.lam_g,
                         n_intervals=warm.n_intervals, degree=warm.degree)
        atomic_write(store / f"{key}.npz", write_npz)
    write_json(store / f"{key}.json", rec, indent=1, non_finite="nan")


class Solver:
    """The solves of one problem on one worker (see the module docstring).

    Parameters
    ----------
    problem : Problem
        System, drive model and OCP options.
    store : Path or None
        Folder of the stored solves; None stores nothing.
    backend : optional
        The numerical side (:class:`optimize.sweep.chains.OcpBackend` by default).
    progress : object with ``put(dict)``, optional
        Receives ``{"tag", "kind", "wind", "role", "status", "cached"}`` after each solve.
    tag : dict, optional
        Fields added to every record and progress event (e.g. the candidate's name).
    extras : callable, optional
        ``extras(trajectory) -> dict`` of further figures of a converged cycle,
        added to its record (None values when the solve failed).
    """

    def __init__(self, problem: Problem, store: Path | None = None, backend: Any = None,
                 progress: Any = None, tag: dict | None = None,
                 extras: Callable[[Any], dict] | None = None) -> None:
        self.problem = problem
        self.store = store
        self.backend = backend or OcpBackend()
        self.progress = progress
        self.tag = dict(tag or {})
        self.extras = extras
        self.records: dict[tuple[str, float], dict] = {}
        self._warm: dict[tuple[str, float], Any] = {}
        self._ocp = None

    def solve(self, kind: str, wind: float, role: str = "grid") -> dict:
        """The record of ``kind`` at ``wind`` [m/s]: loaded, solved earlier, or solved now.

        Record keys: the tag's, ``key, kind, wind_speed_m_s, role, success, status,
        warm_from, avg_p_elec_w, avg_p_mech_w, period_s, peak_speed_rpm,
        peak_torque_nm, rms_torque_nm`` (None when failed), the extras,
        ``wall_time_s, cached``.
        """
        wind = float(wind)
        if (kind, wind) in self.records:
            return self.records[kind, wind]
        key = solve_key(self.problem, kind, wind)
        stored = load_solve(self.store, key) if self.store is not None else None
        if stored is not None:
            rec, warm = stored
            rec = {**rec, "role": role, "cached": True}
        else:
            rec, warm, crashed = self._solve_now(key, kind, wind, role)
            if self.store is not None and not crashed:
                store_solve(self.store, key, rec, warm)
            rec = {**rec, "cached": False}
        self.records[kind, wind] = rec
        if rec["success"] and warm is not None:
            self._warm[kind, wind] = warm
        if self.progress is not None:
            self.progress.put({**self.tag, "kind": kind, "wind": wind, "role": role,
                               "status": rec["status"], "cached": rec["cached"]})
        return rec

    def _solve_now(self, key: str, kind: str, wind: float, role: str) -> tuple[dict, Any, bool]:
        if self._ocp is None:
            self._ocp = self.backend.build(self.problem)
        t0 = time.perf_counter()
        inner = [w for k, w in self._warm if k == kind]
        res, src, crash = None, None, None
        try:
            if inner:
                src = min(inner, key=lambda w: abs(w - wind))
                res = self.backend.solve(self._ocp, kind, wind, self._warm[kind, src])
            if res is None or not res.success:
                src, res = None, self.backend.cold_start(self._ocp, kind, wind)
        except Exception as exc:  # noqa: BLE001 - a crash is this speed's failure, reported
            crash = f"exception: {type(exc).__name__}: {exc}"[:300]
        ok = crash is None and bool(res.success) and math.isfinite(float(res.avg_p_elec_w))
        metrics = cycle_metrics(res.trajectory) if ok else dict.fromkeys(
            ("peak_speed_rpm", "peak_torque_nm", "rms_torque_nm"))
        extras = {}
        if self.extras is not None:
            extras = self.extras(res.trajectory) if ok else dict.fromkeys(self.extras(None))
        rec = {
            **self.tag, "key": key, "kind": kind, "wind_speed_m_s": wind, "role": role,
            "success": ok, "status": crash or str(res.status),
            "warm_from": (f"{src:g} m/s" if src is not None
                          else getattr(res, "start", "cold start")),
            "avg_p_elec_w": float(res.avg_p_elec_w) if ok else None,
            "avg_p_mech_w": float(res.avg_p_mech_w) if ok else None,
            "period_s": float(res.period_s) if ok else None,
            **metrics, **extras,
            "wall_time_s": time.perf_counter() - t0,
        }
        return rec, (res.warm if ok else None), crash is not None


@dataclass(frozen=True)
class SolveTask:
    """One solve: a problem (system, drive model, options), a scenario kind, a wind speed.

    ``tag`` (e.g. ``{"candidate": "x1"}``) is copied into the record and progress events.
    """

    problem: Problem
    kind: str
    wind_speed_m_s: float
    tag: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class _Chain:
    problem: Problem
    kind: str
    winds: tuple[float, ...]
    tag: tuple[tuple[str, Any], ...]
    store: Path | None
    backend: Any
    refine_site: Any


def _run_chain(chain: _Chain, progress: Any = None) -> list[dict]:
    solver = Solver(chain.problem, chain.store, chain.backend, progress, dict(chain.tag))
    for w, _ in continuation_order(chain.winds):
        solver.solve(chain.kind, w)
    if chain.refine_site is not None:
        from energy.adaptive import refine_grid

        refine_grid(lambda w: solver.solve(chain.kind, round(float(w), 6))["avg_p_elec_w"],
                    chain.winds, chain.refine_site)
    return [solver.records[k] for k in sorted(solver.records, key=lambda k: k[1])]


def solve_tasks(tasks: Sequence[SolveTask], store: Path | None = None, *, workers: int = 2,
                scheduler: str | None = None, handle: Any = None, backend: Any = None,
                refine_site: Any = None,
                on_event: Callable[[dict], None] | None = None) -> list[dict]:
    """Solve every task; the records of each chain, sorted by wind speed, chain after chain.

    Tasks of one problem, kind and tag form one chain (one executor task), solved
    along :func:`optimize.sweep.plan.continuation_order` of their wind speeds.
    With ``refine_site`` each chain then adds the wind speeds where its electrical
    power curve bends for that site (:func:`energy.adaptive.refine_grid`).
    ``handle`` is an open :class:`optimize.sweep.executors.ExecutorHandle`;
    without it the local process pool of ``workers`` (or the Dask cluster at
    ``scheduler``) is opened. ``on_event`` receives the solvers' progress events.
    A chain whose worker died reports its speeds failed with status
    ``"worker error: <type>: <message>"``.
    """
    from optimize.sweep.executors import open_executor, run_tasks

    groups: dict[tuple, list[SolveTask]] = {}
    for t in tasks:
        groups.setdefault((t.problem.key, t.kind, t.tag), []).append(t)
    chains = [_Chain(g[0].problem, g[0].kind,
                     tuple(sorted({float(t.wind_speed_m_s) for t in g})), g[0].tag, store,
                     backend, refine_site)
              for g in groups.values()]

    def run(h: Any) -> list:
        return run_tasks(h.executor, _run_chain, chains, h.channel, on_event)

    if handle is None:
        with open_executor(workers, scheduler) as h:
            futures = run(h)
    else:
        futures = run(handle)
    records = []
    for chain, fut in zip(chains, futures, strict=True):
        exc = fut.exception()
        if exc is None:
            records.extend(fut.result())
            continue
        status = f"worker error: {type(exc).__name__}: {exc}"[:300]
        records.extend({**dict(chain.tag), "key": solve_key(chain.problem, chain.kind, w),
                        "kind": chain.kind, "wind_speed_m_s": w, "role": "grid",
                        "success": False, "status": status, "cached": False}
                       for w in chain.winds)
    return records
