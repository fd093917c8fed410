"""Drive sizing: electrical AEP against drive rating over candidate drives (``bench size``).

A candidate is a power model with its rating (:class:`kernel.drive.Drive`):
the short-time peak torque and speed limits, and the continuous rating: the RMS drum
torque over the cycle at most the continuous torque (the RMS-torque row of the
``[drive]`` in force), or, when the system
states a winding limit and the power model has a thermal model, the winding
temperature of the cycle within that limit (sizing by heat, :mod:`optimize.model.thermal`). It is a
``power_model.json`` of its own, or the reference drive scaled by a
torque-rating scale ``s``.

Scaling law
-----------
The similarity law of :func:`optimize.model.drivetrain.carry_power_model` at the same
speed rating (``k_n = 1``, ``k_T = s``): ``P_s(n, T) = s P_1(n, T / s)``, a drive
of ``s`` times the torque rating behaves like ``s`` reference drives sharing the
torque on one shaft (for a term ``c n^i T^j``: ``c -> s^(1 - j) c``). Rating:
continuous torque ``s T_cont``, peak torque ``s T_peak``, the same speed limit,
nominal power ``s P_nom``, a torque-speed envelope's torques ``s T(n)``; the system's other
limits are kept. The reference drive x1 is the system's drive as ``bench optimize`` flies
it: peak torque its ``max_torque_nm``, the RMS torque bound of its continuous rating only
when below that (``rms_torque_limit_nm`` of its ``[drive]`` in force,
:meth:`optimize.system.system.System.in_force`). A thermal model is carried with the
losses: ``r_th / s``, ``c_th s``, the time constant, the copper coefficient and the
temperatures kept (``s`` reference drives side by side, each with
its own cooling), so every candidate reaches the reference's temperature at
corresponding points and the winding limit stays the system's.

Resumable sweep
---------------
The solves go through the solve service (:mod:`optimize.service`): each is
stored under the SHA-256 of its inputs (the candidate's model hash, the OCP
options, the wind speed, objective and the system's hash:
:func:`optimize.service.solve_key`) as ``solves/<key>.json`` (figures) and
``solves/<key>.npz`` (primal and dual vectors, the next solve's warm start),
each written atomically, with the hashes of their content and of the problem they
solve. A re-run loads every stored solve that passes its checks instead of solving it,
so an interrupted sweep continues where it stopped; a stored solve that does not (an
edited, truncated or foreign file) is named and solved again
(:func:`optimize.service.store.read_solve`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from optimize.door import CALL_WALL_LIMIT_S

#: the scenario kind a sizing solves: the electrical objective within the drive's limits
SIZING_KIND = "elec-lim"


@dataclass(frozen=True)
class Candidate:
    """A drive to size.

    Attributes
    ----------
    name : str
    drive : kernel.drive.Drive
        Its rating: ``continuous_torque_nm`` (RMS drum torque over the cycle at most
        this), ``max_torque_nm`` (short-time peak), ``max_speed_rpm``, and
        ``nominal_power_w`` (the capacity factor's and the sizing axis' rating); and its
        losses, ``drive.power_model``.
    scale : float or None
        Torque-rating scale when made by :func:`scaled_candidates`.
    path : Path or None
        The power-model file it was read from (``--models``); None for a scaled one.
    """

    name: str
    drive: Any
    scale: float | None = None
    path: Path | None = None

    @property
    def rated_torque_nm(self) -> float:
        """Continuous rating [N m]."""
        return self.drive.continuous_torque_nm

    @property
    def peak_torque_nm(self) -> float:
        """Short-time torque limit [N m]."""
        return self.drive.max_torque_nm

    @property
    def max_speed_rpm(self) -> float:
        """Speed limit [rpm]."""
        return self.drive.max_speed_rpm

    @property
    def nominal_power_w(self) -> float:
        """Nominal power [W]."""
        return self.drive.nominal_power_w

    def flown_in(self, system: Any) -> Any:
        """``system`` (kite, tether, winch, wind and bounds) with this drive in force, as
        ``bench optimize`` flies the system's drive: x1 flies its limits exactly; a scaled
        candidate's envelope table scaled with it (a base speed scales with
        ``max_torque_nm``)."""
        table = system.drive.envelope_torque_nm
        scaled = (None if self.scale is None or table is None
                  else tuple(self.scale * t for t in table))
        return system.in_force(self.drive, envelope_torque_nm=scaled)

    def check(self, system: Any) -> None:
        """Refuse, before any solve, a candidate ``bench optimize`` would refuse as the
        system's drive (:func:`optimize.system.contradictions.check_drive`): its messages
        begin with the candidate's name."""
        from optimize.door import check_drive

        how = f"--models {self.path}" if self.path is not None else f"--scales {self.scale:g}"
        check_drive(self.flown_in(system), self.drive.power_model, self.path, (SIZING_KIND,),
                    source=f"candidate {self.name} ({how})", rating_source=self.drive.source)

    def problem(self, n_intervals: int, degree: int, system: Any,
                call_time_limit_s: float = CALL_WALL_LIMIT_S) -> Any:
        """The OCP problem (:class:`optimize.service.builder.Problem`) of this drive in
        ``system`` on ``n_intervals`` x ``degree``, a solver call stopped after
        ``call_time_limit_s`` [s] (``--call-time-limit``)."""
        from optimize.door import Discretization, OcpOptions, Problem, SolverOptions

        return Problem.for_system(self.flown_in(system), self.drive.power_model, OcpOptions(
            Discretization(n_intervals, degree),
            solver=SolverOptions(call_time_limit_s=call_time_limit_s)))


def scaled_candidates(reference: Any, scales: tuple[float, ...]) -> list[Candidate]:
    """Candidates of the reference drive scaled by each ``s`` (see the module's law).

    Parameters
    ----------
    reference : kernel.drive.Drive
        The reference drive: its rating, ``continuous_torque_nm`` stated, and its losses
        (``power_model``).
    scales : tuple of float
        Torque-rating scales ``s`` > 0.
    """
    from optimize.door import carry_power_model

    base, out = reference.power_model, []
    for s in scales:
        scaled = reference.with_losses(None).scaled(
            1.0, s, f"{reference.source}; x{s:g} torque rating (bench size)",
            keep=("max_p_elec_w",))
        model = carry_power_model(base, 1.0, s, drive=scaled,
                                  name=f"{base.name} x{s:g} torque rating")
        out.append(Candidate(f"x{s:g}", scaled.with_losses(model), s))
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
    reference: str | None = None  # the candidate the others start from (reference_candidate)


def candidate_row(c: Candidate) -> dict:
    """A candidate's name, scale and the limits it flies, as its row of
    :func:`candidate_table` begins."""
    return {"candidate": c.name, "scale": c.scale, "rated_torque_nm": c.rated_torque_nm,
            "peak_torque_nm": c.peak_torque_nm, "max_speed_rpm": c.max_speed_rpm}


def candidate_table(candidates: list[Candidate], records: list[dict], site: Any,
                    tolerance: float = 0.02, winding_limit_c: float | None = None
                    ) -> tuple[Any, str | None, str | None]:
    """Electrical AEP per candidate; the best, and the smallest within ``tolerance`` of it.

    ``winding_limit_c`` is the system's winding limit [degC] (the continuous rating in
    place of the RMS torque when the candidates' power model has a thermal model).

    Returns
    -------
    (DataFrame, str or None, str or None)
        Rows ``candidate, scale, rated_torque_nm, peak_torque_nm, max_speed_rpm,
        peak_torque_flown_nm, peak_speed_flown_rpm`` (the largest over its converged
        solves), ``nominal_power_w, n_converged, n_winds, aep_elec_mwh, capacity_factor_elec,
        aep_share_of_best, rms_bound_active_at, thermal_bound_active_at,
        peak_winding_temperature_c``; the best candidate's name and the chosen one.
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
        hottest = [r.get("peak_winding_temperature_c") for r in ok
                   if r.get("peak_winding_temperature_c") is not None]
        hot = [r["wind_speed_m_s"] for r in ok if winding_limit_c is not None
               and r.get("peak_winding_temperature_c") is not None
               and r["peak_winding_temperature_c"] >= winding_limit_c - 1e-3 * abs(
                   winding_limit_c)]
        rows.append({
            **candidate_row(c),
            "peak_torque_flown_nm": _largest(ok, "peak_torque_nm"),
            "peak_speed_flown_rpm": _largest(ok, "peak_speed_rpm"),
            "nominal_power_w": c.nominal_power_w, "n_converged": len(ok), "n_winds": len(recs),
            "aep_elec_mwh": aep,
            "capacity_factor_elec": (None if aep is None
                                     else aep * 1e6 / 8760.0 / c.nominal_power_w),
            "rms_bound_active_at": "" if hottest else ",".join(f"{w:g}" for w in active),
            "thermal_bound_active_at": ",".join(f"{w:g}" for w in hot),
            "peak_winding_temperature_c": max(hottest) if hottest else None,
        })
    table = pd.DataFrame(rows).sort_values("rated_torque_nm", kind="stable")
    # a candidate that delivers nothing is no best drive, even when none delivers
    valid = table[table["aep_elec_mwh"].fillna(0.0) > 0]
    if valid.empty:
        table["aep_share_of_best"] = np.nan
        return table.reset_index(drop=True), None, None
    best = valid.loc[valid["aep_elec_mwh"].idxmax()]
    table["aep_share_of_best"] = table["aep_elec_mwh"] / best["aep_elec_mwh"]
    within = valid[valid["aep_elec_mwh"] >= (1 - tolerance) * best["aep_elec_mwh"]]
    chosen = within.sort_values("rated_torque_nm").iloc[0]["candidate"]
    return table.reset_index(drop=True), str(best["candidate"]), str(chosen)


def _largest(records: list[dict], key: str) -> float | None:
    """The largest ``key`` over the solve records that state it (None: none does)."""
    values = [r[key] for r in records if r.get(key) is not None]
    return max(values) if values else None


def limits_text(candidate: dict) -> str:
    """The limits a sizing candidate flew, from its row of :func:`candidate_table` (or of
    ``sizing.json``): torque, RMS torque (when below the torque limit, else implied by
    it), speed."""
    def num(key: str, decimals: int) -> str:
        value = candidate.get(key)
        return "?" if value is None else f"{float(value):.{decimals}f}"

    peak, cont = candidate.get("peak_torque_nm"), candidate.get("rated_torque_nm")
    rms = (f"RMS <= {num('rated_torque_nm', 1)} N m"
           if cont is not None and peak is not None and cont < peak else "RMS implied")
    return (f"torque <= {num('peak_torque_nm', 1)} N m, {rms}, |speed| <= "
            f"{num('max_speed_rpm', 0)} rpm")


#: the columns of the console's candidate table: (heading, row key, format)
CONSOLE_COLUMNS = (
    ("candidate", "candidate", "{}"), ("torque limit N m", "peak_torque_nm", "{:.1f}"),
    ("RMS rating N m", "rated_torque_nm", "{:.1f}"), ("speed limit rpm", "max_speed_rpm", "{:.0f}"),
    ("nominal power W", "nominal_power_w", "{:,.0f}"), ("AEP el MWh/yr", "aep_elec_mwh", "{:.3f}"),
    ("share of best", "aep_share_of_best", "{:.1%}"),
    ("capacity factor", "capacity_factor_elec", "{:.1%}"),
    ("converged", None, None), ("continuous rating binds at m/s", None, None),
)


def format_candidates(table: Any) -> str:
    """The candidate table for the terminal: units in the headings, powers in whole watts,
    shares in per cent, an empty cell where a candidate has no value (no AEP: a failed
    solve), and where its continuous rating binds (RMS torque, or the winding temperature
    with the cycle's peak when the power model carries a thermal model)."""
    rows = []
    for r in table.to_dict(orient="records"):
        cells = []
        for _, key, form in CONSOLE_COLUMNS:
            if key is None:
                continue
            value = r.get(key)
            cells.append("" if value is None or (isinstance(value, float) and math.isnan(value))
                         else form.format(value))
        cells.append(f"{r.get('n_converged')}/{r.get('n_winds')}")
        peak = r.get("peak_winding_temperature_c")
        if peak is not None and not (isinstance(peak, float) and math.isnan(peak)):
            cells.append(f"winding {r.get('thermal_bound_active_at') or 'none'} "
                         f"(peak {peak:.1f} degC)")
        else:
            cells.append(r.get("rms_bound_active_at") or "none")
        rows.append(cells)
    heads = [h for h, _, _ in CONSOLE_COLUMNS]
    widths = [max(len(h), *(len(c[i]) for c in rows)) for i, h in enumerate(heads)]
    line = lambda cells: "  ".join(  # noqa: E731
        c.ljust(w) if i in (0, len(heads) - 1) else c.rjust(w)
        for i, (c, w) in enumerate(zip(cells, widths, strict=True)))
    return "\n".join([line(heads), *map(line, rows)])


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


def size_extending(make_candidates: Any, scales: tuple[float, ...], extend: int,
                   run: Any, refused: list[str] | None = None
                   ) -> tuple[SizingResult, str | None, list[float]]:
    """Size, and while the best drive is a torque-rating scale at the edge of the set, add
    the next scale beyond it (:func:`next_scale`) and size again, up to ``extend`` times.

    ``make_candidates(scales)`` gives the candidates of those scales (plus any others);
    ``run(candidates)`` sizes them (:func:`run_sizing`: solves already stored are loaded,
    so a later round solves only the added scale). Returns the last round's result, with
    each solve and the wall time counted once over the rounds, the edge the best drive
    sits at (:func:`edge_of_set`) and the scales added. A scale beyond the edge whose
    candidate ``make_candidates`` refuses (:class:`~kernel.errors.InputError`: a drive
    that cannot hold the kite, ...) ends the extension; why is appended to ``refused``.
    """
    from kernel.errors import InputError

    scales, added = list(scales), []
    solved, wall = 0, 0.0
    res = edge = None
    while True:
        try:
            candidates = make_candidates(tuple(scales))
        except InputError as exc:
            if res is None:  # the candidates asked for: refused, nothing solved
                raise
            if refused is not None:
                refused.append(f"scale x{added[-1]:g} beyond the edge not sized: "
                               f"{exc.describe()}")
            return res, edge, added[:-1]
        res = run(candidates)
        # a later round loads the solves of the earlier ones: count each solve once
        res = dataclasses.replace(res, n_solved=solved + res.n_solved,
                                  n_cached=res.n_cached - solved,
                                  wall_time_s=wall + res.wall_time_s)
        solved, wall = res.n_solved, res.wall_time_s
        edge = edge_of_set(res.table, res.best)
        scaled = {c.name for c in candidates if c.scale is not None}
        if edge is None or len(added) >= extend or res.best not in scaled:
            return res, edge, added
        added.append(next_scale(tuple(scales), edge))
        scales.append(added[-1])


def reference_candidate(candidates: list[Candidate]) -> Candidate | None:
    """The candidate whose solves the others start from (see :func:`run_sizing`): the
    reference drive x1, else the scaled candidate nearest it in torque rating, else the
    first; None for a single candidate."""
    if len(candidates) < 2:
        return None
    scaled = [c for c in candidates if c.scale is not None]
    return min(scaled, key=lambda c: abs(math.log(c.scale))) if scaled else candidates[0]


def starts_note(records: list[dict], reference: str | None) -> str:
    """How the solves of a sizing started (each record's ``warm_from``), counted, with the
    cold starts named: ``"starts of the 20 solves: 16 from x1's optimum at the same wind
    speed, 3 from the candidate's own neighbouring speed, 1 cold (x1 7 m/s: stored
    guess)"``. A solve loaded from the store counts with the start it was solved from."""
    starts = [(r, r.get("warm_from") or "") for r in records]
    cold = [r for r, w in starts if w and "m/s" not in w]
    borrowed = sum(bool(reference) and w.startswith(f"{reference} ")
                   and r.get("candidate") != reference for r, w in starts)
    own = sum("m/s" in w for _, w in starts) - borrowed
    named = ", ".join(f"{r['candidate']} {r['wind_speed_m_s']:g} m/s: {r['warm_from']}"
                      for r in cold)
    parts = ([f"{borrowed} from {reference}'s optimum at the same wind speed"]
             if reference else []) + [f"{own} from the candidate's own neighbouring speed",
                                      f"{len(cold)} cold" + (f" ({named})" if cold else "")]
    return f"starts of the {len(records)} solves: {', '.join(parts)}"


def idle_lines(table: Any, records: list[dict]) -> list[str]:
    """One line per candidate that got an AEP of 0: every solve converged and none
    delivers energy (each optimum draws power from the grid, its losses above what the
    kite gives it), so it is no choice at this site."""
    lines = []
    for row in table.to_dict(orient="records"):
        if row["aep_elec_mwh"] is None or not row["aep_elec_mwh"] <= 0:
            continue
        draws = [r["avg_p_elec_w"] for r in records
                 if r.get("candidate") == row["candidate"] and r["success"]]
        lines.append(f"{row['candidate']} delivers no energy at any wind speed of the grid "
                     f"(its optima draw {min(draws):.4g} to {max(draws):.4g} W from the grid: "
                     "the drive's losses exceed what the kite gives it): no choice at this "
                     "site; size drives of this kite's power (--scales)")
    return lines


def start_lines(records: list[dict]) -> list[str]:
    """One line per candidate: where each of its solves started (``warm_from``), e.g.
    ``"x0.5 starts: 4 m/s from x1 4 m/s, 7 m/s from x1 7 m/s"``."""
    by: dict[str, list[dict]] = {}
    for r in records:
        by.setdefault(r["candidate"], []).append(r)
    return [f"{c} starts: " + ", ".join(f"{r['wind_speed_m_s']:g} m/s from "
                                          f"{r.get('warm_from') or '?'}"
                                          for r in sorted(rs, key=lambda r: r["wind_speed_m_s"]))
            for c, rs in by.items()]


def run_sizing(candidates: list[Candidate], wind_speeds_m_s: tuple[float, ...], site: Any,
               out: Path, n_intervals: int = 40, degree: int = 4,
               call_time_limit_s: float = CALL_WALL_LIMIT_S, handle: Any = None,
               workers: int = 2, scheduler: str | None = None, show_progress: bool = True,
               tolerance: float = 0.02, adaptive: bool = False,
               system: Any = None, backend: Any = None) -> SizingResult:
    """Run (or resume) the sizing sweep through the solve service (:mod:`optimize.service`):
    one chain of :data:`SIZING_KIND` solves per candidate, stored under ``out/solves``.

    The reference candidate's chain (:func:`reference_candidate`) runs first, from one
    cold start (the stored guess where it fits, else the homotopy); every other
    candidate's solve starts from the reference's optimum at the same wind speed,
    carried to its own drive (:class:`optimize.service.foreign.ForeignStart`: the
    cycle's states and controls as they are, since the drive has no variables of its
    own), then from its own solved neighbour, a cold start last. Each record's
    ``warm_from`` says which (docs/schemas.md §8).

    ``handle`` is an open :class:`optimize.service.executors.ExecutorHandle`; without it
    a local process pool of ``workers`` (or the Dask cluster at ``scheduler``) is opened.
    With ``adaptive`` each candidate's grid is refined where its curve bends
    (:mod:`energy.adaptive`), so candidates may end with different speeds.
    ``system`` (an :class:`optimize.system.system.System`, default the shipped one)
    gives the kite, tether, winch, wind and bounds every candidate is sized for.
    ``backend`` replaces the CasADi OCP (:class:`optimize.service.builder.OcpBackend`).
    A solver crash fails that solve (status ``exception: ...``) and so its
    candidate's AEP, never the sweep.
    """
    from tqdm import tqdm

    from energy.adaptive import refine_grid
    from energy.refine import solve_counter
    from optimize.door import (
        Refinement,
        Scenario,
        SolveTask,
        attempt_line,
        load_system,
        solve_tasks,
    )

    system = system if system is not None else load_system()
    tasks = [SolveTask(c.problem(n_intervals, degree, system, call_time_limit_s),
                       Scenario.of_kind(SIZING_KIND, w),
                       (("candidate", c.name),))
             for c in candidates for w in wind_speeds_m_s]
    refinement = partial(Refinement, site=site, grid=refine_grid) if adaptive else None
    first = reference_candidate(candidates)
    reference = None if first is None else (("candidate", first.name),)
    bar = (solve_counter("size", show_progress) if adaptive else
           tqdm(total=len(tasks), unit="solve", desc="size", disable=not show_progress))
    counts = {"solved": 0, "cached": 0}

    def on_event(ev: dict) -> None:
        if "attempt" in ev:  # a solver run starts or ends: say which
            bar.set_postfix_str(f"{ev['candidate']} {attempt_line(ev)}")
            return
        counts["cached" if ev["cached"] else "solved"] += 1
        bar.set_postfix_str(f"{ev['candidate']} {ev['wind_speed_m_s']:g} m/s: "
                            f"{'stored' if ev['cached'] else ev['status']}")
        bar.update(1)

    t0 = time.perf_counter()
    if handle is None:
        from optimize.door import open_executor

        with open_executor(workers, scheduler) as handle:
            records = solve_tasks(tasks, Path(out) / "solves", handle=handle, backend=backend,
                                  refine=refinement, on_event=on_event, reference=reference)
    else:
        records = solve_tasks(tasks, Path(out) / "solves", handle=handle, backend=backend,
                              refine=refinement, on_event=on_event, reference=reference)
    description = handle.description
    bar.close()
    wall = time.perf_counter() - t0
    table, best, chosen = candidate_table(candidates, records, site, tolerance,
                                          system.drive.max_winding_temperature_c)
    return SizingResult(table, records, best, chosen, wall, description, counts["solved"],
                        counts["cached"], None if first is None else first.name)
