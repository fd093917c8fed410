"""Drive sizing: electrical AEP against drive rating over candidate drives (``bench size``).

A candidate is a power model with its rating (:class:`bench.drive.DriveRating`):
the short-time peak torque and speed limits, and the continuous rating (RMS drum
torque over the cycle at most the continuous torque,
:class:`optimize.problem.options.Limits` ``max_rms_torque_nm``). It is a
``power_model.json`` of its own, or the reference drive scaled by a
torque-rating scale ``s``.

Scaling law
-----------
The similarity law of :func:`optimize.model.drive.carry_power_model` at the same
speed rating (``k_n = 1``, ``k_T = s``): ``P_s(n, T) = s P_1(n, T / s)``, a drive
of ``s`` times the torque rating behaves like ``s`` reference drives sharing the
torque on one shaft (for a term ``c n^i T^j``: ``c -> s^(1 - j) c``). Rating:
continuous torque ``s T_cont``, peak torque ``s T_peak``, the same speed limit,
nominal power ``s P_nom``; the system's other limits are kept.

Resumable sweep
---------------
Each solve is stored under the SHA-256 of its inputs (the candidate's model
hash, the OCP options, the wind speed and objective: :func:`solve_key`) as
``solves/<key>.json`` (figures) and ``solves/<key>.npz`` (primal and dual
vectors, the next solve's warm start), each written atomically. A re-run loads
every stored solve instead of solving it, so an interrupted sweep continues
where it stopped.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bench.files import atomic_write, write_text_atomic

#: bump when the meaning of a stored solve changes (invalidates every stored solve)
STORE_VERSION = 1

@dataclass(frozen=True)
class Candidate:
    """A drive to size: power model and rating.

    Attributes
    ----------
    name : str
    model : fitting.model_file.PowerModel
    rating : bench.drive.DriveRating
        Its limits: ``continuous_torque_nm`` (RMS drum torque over the cycle at most
        this), ``max_torque_nm`` (short-time peak), ``max_speed_rpm``, and
        ``nominal_power_w`` (the capacity factor's and the sizing axis' rating).
    scale : float or None
        Torque-rating scale when made by :func:`scaled_candidates`.
    """

    name: str
    model: Any
    rating: Any
    scale: float | None = None

    @property
    def rated_torque_nm(self) -> float:
        """Continuous rating [N m]."""
        return self.rating.continuous_torque_nm

    @property
    def peak_torque_nm(self) -> float:
        """Short-time torque limit [N m]."""
        return self.rating.max_torque_nm

    @property
    def max_speed_rpm(self) -> float:
        """Speed limit [rpm]."""
        return self.rating.max_speed_rpm

    @property
    def nominal_power_w(self) -> float:
        """Nominal power [W]."""
        return self.rating.nominal_power_w

    def ocp_options(self, n_intervals: int, degree: int, system: Any) -> Any:
        """The OCP options of ``system`` (bounds) with this drive's limits and rating.

        Parameters
        ----------
        n_intervals, degree : int
            Collocation intervals and Radau degree.
        system : optimize.system.system.System
            The kite, tether, winch, wind and bounds the candidate is sized for.
        """
        from optimize.problem.options import Discretization, OcpOptions

        options = system.ocp_options(OcpOptions(Discretization(n_intervals, degree)),
                                     self.rating)
        return options.replace(limits={"max_rms_torque_nm": self.rated_torque_nm})


def scaled_candidates(base: Any, rating: Any, scales: tuple[float, ...]) -> list[Candidate]:
    """Candidates of the reference drive scaled by each ``s`` (see the module's law).

    Parameters
    ----------
    base : fitting.model_file.PowerModel
        The reference drive's losses (at ``rating``).
    rating : bench.drive.DriveRating
        The reference drive's rating, ``continuous_torque_nm`` stated.
    scales : tuple of float
        Torque-rating scales ``s`` > 0.
    """
    from optimize.model.drive import carry_power_model

    out = []
    for s in scales:
        scaled = dataclasses.replace(
            rating, nominal_power_w=s * rating.nominal_power_w,
            max_torque_nm=s * rating.max_torque_nm,
            continuous_torque_nm=s * rating.continuous_torque_nm,
            source=f"{rating.source}; x{s:g} torque rating (bench size)")
        model = carry_power_model(base, 1.0, s, drive=scaled.to_dict(),
                                  name=f"{base.name} x{s:g} torque rating")
        out.append(Candidate(f"x{s:g}", model, scaled, s))
    return out


def solve_key(candidate: Candidate, options: Any, wind_m_s: float, system_sha256: str) -> str:
    """SHA-256 (hex) of everything a sizing solve (elec-lim) depends on (the system file's
    hash too)."""
    return scenario_key(candidate.model.sha256, options, wind_m_s, "electrical", True,
                        system_sha256)


def scenario_key(model_sha256: str, options: Any, wind_m_s: float, objective: str,
                 drive_limits: bool, system_sha256: str | None = None) -> str:
    """SHA-256 (hex) of everything one stored solve depends on (the store's file name).

    ``system_sha256`` (the kite system's hash) enters the key when given (always for
    ``bench size``; ``bench aep --refine`` of a sweep made before system files has none).
    """
    data = {"version": STORE_VERSION, "model": model_sha256,
            "options": dataclasses.asdict(options), "wind_m_s": float(wind_m_s),
            "objective": objective, "drive_limits": bool(drive_limits)}
    if system_sha256 is not None:
        data["system"] = system_sha256
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class SizingTask:
    """One candidate's chain of solves over the wind speeds (one executor task)."""

    candidate: Candidate
    winds: tuple[float, ...]
    n_intervals: int
    degree: int
    store: Path
    refine_site: Any = None  # a site distribution: refine the grid adaptively for it
    system: Any = None  # optimize.system.system.System; None = the shipped default system


def _chain_order(winds: tuple[float, ...]) -> list[float]:
    """Middle speed first, then outwards (each solve warm-starts from its inner neighbour)."""
    mid = (len(winds) - 1) // 2
    order = [winds[mid]]
    for k in range(1, len(winds)):
        if mid + k < len(winds):
            order.append(winds[mid + k])
        if mid - k >= 0:
            order.append(winds[mid - k])
    return order


def load_solve(store: Path, key: str) -> tuple[dict, Any] | None:
    """A stored solve (figures, warm start) or None when absent or unreadable."""
    from optimize.solve.result import Solution

    js, npz = store / f"{key}.json", store / f"{key}.npz"
    if not js.is_file():
        return None
    try:
        rec = json.loads(js.read_text())
        warm = None
        if npz.is_file():
            with np.load(npz) as f:
                warm = Solution(f["w"], f["lam_x"], f["lam_g"], int(f["n_intervals"]),
                                int(f["degree"]))
    except (OSError, ValueError, KeyError, json.JSONDecodeError):
        return None
    return rec, warm


def store_solve(store: Path, key: str, rec: dict, warm: Any) -> None:
    if warm is not None:  # the warm start first: a json without its npz is still usable
        def write_npz(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                np.savez(fh, w=warm.w, lam_x=warm.lam_x, lam_g=warm.lam_g,
                         n_intervals=warm.n_intervals, degree=warm.degree)
        atomic_write(store / f"{key}.npz", write_npz)
    write_text_atomic(store / f"{key}.json", json.dumps(rec, indent=1, allow_nan=True))


def run_candidate(task: SizingTask, progress: Any = None) -> list[dict]:
    """Solve (or load) elec-lim at every wind speed for one candidate; returns the records.

    With ``task.refine_site`` the grid is then refined where the candidate's curve
    bends (:func:`energy.adaptive.refine_grid`); added speeds are stored like the others.
    """
    from optimize.model.kite_model import kite_dae
    from optimize.problem.ocp import build_ocp
    from optimize.problem.scenario import Scenario
    from optimize.solve.solve import solve, start
    from optimize.system.system import load_system

    c = task.candidate
    system = task.system if task.system is not None else load_system()
    options = c.ocp_options(task.n_intervals, task.degree, system)
    task.store.mkdir(parents=True, exist_ok=True)
    ocp = None
    records: dict[float, dict] = {}
    warms: dict[float, Any] = {}

    def solve_at(wind: float) -> dict:
        nonlocal ocp
        if wind in records:
            return records[wind]
        key = solve_key(c, options, wind, system.sha256)
        stored = load_solve(task.store, key)
        if stored is not None:
            rec, warm = stored
            records[wind], warms[wind] = {**rec, "cached": True}, warm
        else:
            if ocp is None:
                ocp = build_ocp(kite_dae(*system.model_params()), c.model, options,
                                system=system)
            scenario = Scenario(wind, "electrical", True)
            inner = [w for w in warms if warms[w] is not None]
            t0 = time.perf_counter()
            res = None
            if inner:
                src = min(inner, key=lambda w: abs(w - wind))
                res = solve(ocp, scenario, warms[src])
            if res is None or not res.success:
                res = start(ocp, scenario)
            traj = res.trajectory
            ok = bool(res.success)
            rec = {
                "key": key, "candidate": c.name, "wind_speed_m_s": wind,
                "success": ok, "status": res.status,
                "avg_p_elec_w": float(res.avg_p_elec_w) if ok else None,
                "avg_p_mech_w": float(res.avg_p_mech_w) if ok else None,
                "period_s": float(res.period_s) if ok else None,
                "rms_torque_nm": (float(np.sqrt(np.sum(traj["weight"] * traj["torque_nm"] ** 2)))
                                  if ok else None),
                "peak_torque_nm": float(traj["torque_nm"].max()) if ok else None,
                "peak_speed_rpm": float(traj["speed_rpm"].abs().max()) if ok else None,
                "wall_time_s": time.perf_counter() - t0,
            }
            store_solve(task.store, key, rec, res.warm if ok else None)
            records[wind], warms[wind] = {**rec, "cached": False}, (res.warm if ok else None)
        if progress is not None:
            r = records[wind]
            progress.put({"candidate": c.name, "wind": wind, "status": r["status"],
                          "cached": r["cached"]})
        return records[wind]

    for wind in _chain_order(task.winds):
        solve_at(wind)
    if task.refine_site is not None:
        from energy.adaptive import refine_grid

        refine_grid(lambda w: solve_at(round(float(w), 6))["avg_p_elec_w"], task.winds,
                    task.refine_site)
    return [records[w] for w in sorted(records)]


@dataclass(frozen=True)
class SizingResult:
    """The sweep's outcome: one row per candidate and every solve record."""

    table: Any  # pandas.DataFrame, one row per candidate (see :func:`candidate_table`)
    records: list[dict]
    best: str | None
    chosen: str | None
    wall_time_s: float
    executor: str
    n_solved: int
    n_cached: int


def candidate_table(candidates: list[Candidate], records: list[dict], site: Any,
                    tolerance: float = 0.02) -> tuple[Any, str | None, str | None]:
    """Electrical AEP per candidate; the best, and the smallest within ``tolerance`` of it.

    Returns
    -------
    (DataFrame, str or None, str or None)
        Rows ``candidate, scale, rated_torque_nm, peak_torque_nm, max_speed_rpm,
        nominal_power_w, n_converged, n_winds, aep_elec_mwh, capacity_factor_elec,
        aep_share_of_best, rms_bound_active_at``; the best candidate's name and the chosen one.
        A candidate with a failed solve gets no AEP (never an AEP from fewer points).
    """
    import pandas as pd

    from energy.aep import aep_mwh

    rows = []
    for c in candidates:
        recs = sorted((r for r in records if r["candidate"] == c.name),
                      key=lambda r: r["wind_speed_m_s"])
        ok = [r for r in recs if r["success"]]
        aep = None
        if ok and len(ok) == len(recs):
            aep = aep_mwh(np.array([r["wind_speed_m_s"] for r in ok]),
                          np.array([r["avg_p_elec_w"] for r in ok]), site)
        active = [r["wind_speed_m_s"] for r in ok
                  if r["rms_torque_nm"] is not None
                  and r["rms_torque_nm"] >= (1 - 1e-3) * c.rated_torque_nm]
        rows.append({
            "candidate": c.name, "scale": c.scale, "rated_torque_nm": c.rated_torque_nm,
            "peak_torque_nm": c.peak_torque_nm, "max_speed_rpm": c.max_speed_rpm,
            "nominal_power_w": c.nominal_power_w, "n_converged": len(ok), "n_winds": len(recs),
            "aep_elec_mwh": aep,
            "capacity_factor_elec": (None if aep is None
                                     else aep * 1e6 / 8760.0 / c.nominal_power_w),
            "rms_bound_active_at": ",".join(f"{w:g}" for w in active),
        })
    table = pd.DataFrame(rows).sort_values("rated_torque_nm", kind="stable")
    valid = table.dropna(subset=["aep_elec_mwh"])
    if valid.empty:
        table["aep_share_of_best"] = np.nan
        return table.reset_index(drop=True), None, None
    best = valid.loc[valid["aep_elec_mwh"].idxmax()]
    table["aep_share_of_best"] = table["aep_elec_mwh"] / best["aep_elec_mwh"]
    within = valid[valid["aep_elec_mwh"] >= (1 - tolerance) * best["aep_elec_mwh"]]
    chosen = within.sort_values("rated_torque_nm").iloc[0]["candidate"]
    return table.reset_index(drop=True), str(best["candidate"]), str(chosen)


def edge_of_set(table: Any, best: str | None) -> str | None:
    """Whether the best candidate is the largest or smallest drive that got an AEP.

    Returns
    -------
    str or None
        ``"largest"`` or ``"smallest"`` (by rated torque) when the best candidate is at
        that end of the candidates with an AEP, so a drive beyond it may be better still;
        None when it lies inside, or no candidate has an AEP.
    """
    valid = table.dropna(subset=["aep_elec_mwh"]).sort_values("rated_torque_nm", kind="stable")
    if best is None or valid.empty:
        return None
    if valid.iloc[-1]["candidate"] == best:
        return "largest"
    if valid.iloc[0]["candidate"] == best:
        return "smallest"
    return None


def next_scale(scales: tuple[float, ...], edge: str) -> float:
    """The torque-rating scale one step beyond the ``edge`` (``"largest"``/``"smallest"``) of
    ``scales``, continuing the ratio of the two outermost ones (x2 or /2 with one scale),
    rounded to three significant digits."""
    ordered = sorted(scales)
    outer, inner = (ordered[-1], ordered[-2:-1]) if edge == "largest" else (ordered[0],
                                                                          ordered[1:2])
    ratio = outer / inner[0] if inner else (2.0 if edge == "largest" else 0.5)
    return float(f"{outer * ratio:.3g}")


def run_sizing(candidates: list[Candidate], winds: tuple[float, ...], site: Any, out: Path,
               n_intervals: int = 40, degree: int = 4, handle: Any = None, workers: int = 2,
               scheduler: str | None = None, show_progress: bool = True,
               tolerance: float = 0.02, adaptive: bool = False,
               system: Any = None) -> SizingResult:
    """Run (or resume) the sizing sweep: one task per candidate on the executor.

    ``handle`` is an open :class:`optimize.sweep.executors.ExecutorHandle`; without it
    a local process pool of ``workers`` (or the Dask cluster at ``scheduler``) is opened.
    With ``adaptive`` each candidate's grid is refined where its curve bends
    (:mod:`energy.adaptive`), so candidates may end with different speeds.
    ``system`` (an :class:`optimize.system.system.System`, default the shipped one)
    gives the kite, tether, winch, wind and bounds every candidate is sized for.
    """
    from tqdm import tqdm

    from optimize.sweep.executors import open_executor, run_tasks

    store = Path(out) / "solves"
    tasks = [SizingTask(c, tuple(winds), n_intervals, degree, store,
                        site if adaptive else None, system) for c in candidates]
    bar = tqdm(total=len(tasks) * len(winds), unit="solve", desc="size",
               disable=not show_progress)
    counts = {"solved": 0, "cached": 0}

    def on_event(ev: dict) -> None:
        counts["cached" if ev["cached"] else "solved"] += 1
        if bar.n >= bar.total:  # an adaptive grid adds speeds
            bar.total += 1
        bar.set_postfix_str(f"{ev['candidate']} {ev['wind']:g} m/s: "
                            f"{'stored' if ev['cached'] else ev['status']}")
        bar.update(1)

    t0 = time.perf_counter()
    if handle is None:
        with open_executor(workers, scheduler) as h:
            futures = run_tasks(h.executor, run_candidate, tasks, h.channel, on_event)
            description = h.description
    else:
        futures = run_tasks(handle.executor, run_candidate, tasks, handle.channel, on_event)
        description = handle.description
    bar.close()
    wall = time.perf_counter() - t0
    records = []
    for task, f in zip(tasks, futures, strict=True):
        exc = f.exception()
        if exc is None:
            records.extend(f.result())
            continue
        # a crashed task fails its candidate (reported, no AEP), never the sweep
        status = f"worker error: {type(exc).__name__}: {exc}"[:300]
        records.extend({"key": None, "candidate": task.candidate.name, "wind_speed_m_s": w,
                        "success": False, "status": status, "avg_p_elec_w": None,
                        "avg_p_mech_w": None, "period_s": None, "rms_torque_nm": None,
                        "peak_torque_nm": None, "peak_speed_rpm": None, "wall_time_s": None,
                        "cached": False} for w in task.winds)
    table, best, chosen = candidate_table(candidates, records, site, tolerance)
    return SizingResult(table, records, best, chosen, wall, description, counts["solved"],
                        counts["cached"])
