"""Drive sizing: electrical AEP against drive rating over candidate drives (``bench size``).

A candidate is a power model with its limits: the short-time peak torque and
speed, and the continuous rating (RMS drum torque over the cycle at most the
rated torque, :class:`optimize.problem.ocp.OcpOptions` ``max_rms_torque_nm``).
It is a ``power_model.json`` of its own, or the reference model scaled by a
torque-rating scale ``s``.

Scaling law
-----------
``P_s(n, T) = s P_1(n, T / s)``: a drive of ``s`` times the torque rating at the
same speed rating behaves like ``s`` reference drives sharing the torque on one
shaft. For a term ``c n^i T^j`` that is ``c -> s^(1 - j) c``; for paper eq. 4:
constant losses ``a0 -> s a0`` and speed losses ``a1 n^2 -> s a1 n^2`` grow with
the active volume, copper losses ``a2 T^2 -> a2 T^2 / s`` fall (current per unit
torque ~ 1/s, resistance ~ s), and the conversion term ``a3 n T`` is unchanged.
It is the axial (stack-length) scaling of a permanent-magnet machine with end
effects neglected (S. Stipetic, D. Zarko, M. Popescu, "Ultra-fast axial and
radial scaling of synchronous permanent magnet machines", IET Electric Power
Applications 10(7), 2016; J. Pyrhonen, T. Jokinen, V. Hrabovcova, "Design of
Rotating Electrical Machines", Wiley 2008, ch. 1: torque ~ rotor volume). The
covariance scales with the same factors. Limits: rated torque ``s T_rated``,
peak torque ``overload x`` rated, the same speed limit, nominal power ``s P_nom``.

Resumable sweep
---------------
The solves go through the solve service (:mod:`optimize.service`): each is
stored under the SHA-256 of its inputs (the candidate's model hash, the OCP
options, the wind speed, objective and the system's hash:
:func:`optimize.service.solve_key`) as ``solves/<key>.json`` (figures) and
``solves/<key>.npz`` (primal and dual vectors, the next solve's warm start),
each written atomically. A re-run loads every stored solve instead of solving
it, so an interrupted sweep continues where it stopped.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: default short-time peak torque over rated torque: the paper's drive can overload up to
#: 500 % in torque (Stuyts et al. 2015, section II)
DEFAULT_OVERLOAD = 5.0

#: the scenario kind a sizing solves: the electrical objective within the drive's limits
SIZING_KIND = "elec-lim"


def scaled_model(base: Any, s: float, name: str | None = None) -> Any:
    """The power model of a drive with ``s`` times the torque rating (``c_ij -> s^(1-j) c_ij``).

    Parameters
    ----------
    base : fitting.power_model.PowerModel
    s : float
        Torque-rating scale, > 0.
    """
    if not (math.isfinite(s) and s > 0):
        raise ValueError(f"scale must be > 0, got {s}")
    f = np.array([s ** (1 - j) for _, j in base.terms])
    cov = None
    if base.covariance_rpm is not None:
        cov = tuple(map(tuple, np.array(base.covariance_rpm) * np.outer(f, f)))
    provenance = {"scaled_from": base.sha256, "torque_rating_scale": s,
                  "law": "P_s(n, T) = s P_1(n, T/s): c_ij -> s^(1-j) c_ij"}
    changes = {}
    drive = getattr(base, "drive", None)
    if drive is not None:  # the rating scales with the drive: torque and power, not speed
        changes["drive"] = {**drive, "nominal_power_w": drive["nominal_power_w"] * s,
                            "max_torque_nm": drive["max_torque_nm"] * s,
                            "source": f"{drive.get('source', '')}; scaled x{s:g} (bench size)"}
    return dataclasses.replace(
        base, coefficients_rpm=tuple(np.array(base.coefficients_rpm) * f), covariance_rpm=cov,
        nominal_power_w=base.nominal_power_w * s,
        name=name or f"{base.name} x{s:g} torque rating", provenance=provenance, **changes,
    )


@dataclass(frozen=True)
class Candidate:
    """A drive to size: power model and limits.

    Attributes
    ----------
    name : str
    model : fitting.power_model.PowerModel
    rated_torque_nm : float
        Continuous rating: RMS drum torque over the cycle at most this [N m].
    peak_torque_nm : float
        Short-time torque limit [N m].
    max_speed_rpm : float
        Speed limit [rpm].
    nominal_power_w : float
        Rating for the capacity factor and the sizing axis [W].
    scale : float or None
        Torque-rating scale when made by :func:`scaled_model`.
    """

    name: str
    model: Any
    rated_torque_nm: float
    peak_torque_nm: float
    max_speed_rpm: float
    nominal_power_w: float
    scale: float | None = None

    def ocp_options(self, n_intervals: int, degree: int, system: Any) -> Any:
        """The OCP options of ``system`` (bounds) with this drive's limits and rating.

        Parameters
        ----------
        n_intervals, degree : int
            Collocation intervals and Radau degree.
        system : optimize.system.system.System
            The kite, tether, winch, wind and bounds the candidate is sized for.
        """
        from optimize.problem.ocp import OcpOptions

        base = system.ocp_options(OcpOptions(n_intervals=n_intervals, degree=degree), self.model)
        return dataclasses.replace(base, max_torque_nm=self.peak_torque_nm,
                                   max_speed_rpm=self.max_speed_rpm,
                                   max_rms_torque_nm=self.rated_torque_nm,
                                   nominal_power_w=self.nominal_power_w)

    def problem(self, n_intervals: int, degree: int, system: Any) -> Any:
        """The OCP problem (:class:`optimize.sweep.chains.Problem`) of this drive in ``system``."""
        from optimize.sweep.chains import Problem

        return Problem.for_system(system, self.model, self.ocp_options(n_intervals, degree,
                                                                        system))


def scaled_candidates(base: Any, scales: tuple[float, ...], rated_torque_nm: float,
                      max_speed_rpm: float, overload: float) -> list[Candidate]:
    """Candidates of the reference drive scaled by each ``s`` (see the module's law)."""
    out = []
    for s in scales:
        m = scaled_model(base, s)
        out.append(Candidate(f"x{s:g}", m, s * rated_torque_nm, overload * s * rated_torque_nm,
                             max_speed_rpm, m.nominal_power_w, s))
    return out


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


def run_sizing(candidates: list[Candidate], winds: tuple[float, ...], site: Any, out: Path,
               n_intervals: int = 40, degree: int = 4, handle: Any = None, workers: int = 2,
               scheduler: str | None = None, show_progress: bool = True,
               tolerance: float = 0.02, adaptive: bool = False,
               system: Any = None, backend: Any = None) -> SizingResult:
    """Run (or resume) the sizing sweep through the solve service (:mod:`optimize.service`):
    one chain of :data:`SIZING_KIND` solves per candidate, stored under ``out/solves``.

    ``handle`` is an open :class:`optimize.sweep.executors.ExecutorHandle`; without it
    a local process pool of ``workers`` (or the Dask cluster at ``scheduler``) is opened.
    With ``adaptive`` each candidate's grid is refined where its curve bends
    (:mod:`energy.adaptive`), so candidates may end with different speeds.
    ``system`` (an :class:`optimize.system.system.System`, default the shipped one)
    gives the kite, tether, winch, wind and bounds every candidate is sized for.
    ``backend`` replaces the CasADi OCP (:class:`optimize.sweep.chains.OcpBackend`).
    A solver crash fails that solve (status ``exception: ...``) and so its
    candidate's AEP, never the sweep.
    """
    from tqdm import tqdm

    from optimize.service import SolveTask, solve_tasks
    from optimize.system.system import load_system

    system = system if system is not None else load_system()
    tasks = [SolveTask(c.problem(n_intervals, degree, system), SIZING_KIND, float(w),
                       (("candidate", c.name),))
             for c in candidates for w in winds]
    bar = tqdm(total=len(tasks), unit="solve", desc="size", disable=not show_progress)
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
        from optimize.sweep.executors import open_executor

        with open_executor(workers, scheduler) as handle:
            records = solve_tasks(tasks, Path(out) / "solves", handle=handle, backend=backend,
                                  refine_site=site if adaptive else None, on_event=on_event)
    else:
        records = solve_tasks(tasks, Path(out) / "solves", handle=handle, backend=backend,
                              refine_site=site if adaptive else None, on_event=on_event)
    description = handle.description
    bar.close()
    wall = time.perf_counter() - t0
    table, best, chosen = candidate_table(candidates, records, site, tolerance)
    return SizingResult(table, records, best, chosen, wall, description, counts["solved"],
                        counts["cached"])
