"""Refine the optimize stage's power curves for a site: ``bench aep --refine``.

The sweep's fixed wind grid interpolates linearly across the bends of the curve
(cut-in, a drive limit becoming active). For each scenario kind of an
``optimize_out/`` folder this module solves the wind speeds that
:func:`energy.adaptive.refine_grid` asks for, the electrical and the mechanical
curve of the kind refined together, and returns the curve with those points
added, each marked with its solve's status.

Solves: the first added speed of a kind is preceded by a re-solve of the nearest
converged grid point from the sweep's own cycle there (``trajectories.parquet``,
:func:`sweep_starts`; the stored initial guess when the folder has none): it checks
that the model and OCP options of the manifest reproduce the sweep's power there
(:data:`CHECK_REL_TOL`). Every added speed starts from the nearest solved speed: a
sweep speed's cycle, or a speed solved here (its optimum, multipliers included, is
preferred at equal distance), a cold start last. Each solve is stored
under the hash of its inputs (:func:`optimize.service.solve_key`, same store
layout as ``bench size``), so a re-run loads it instead of solving it. A failed
added solve is kept out of the curve and reported, never dropped silently.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from energy import bands
from energy.adaptive import refine_grid
from energy.curve import OptimizeRun, PowerCurve
from kernel.errors import InputError
from kernel.files import parse_toml
from optimize.door import failure_reason, rejected_lines
from optimize.sweep_folder import sweep_drive

#: the check re-solve must give the sweep's average electrical power within this share
#: of the curve's largest |P_elec|: IPOPT's tolerance (1e-6 scaled) reproduces the same
#: local optimum far closer; a larger gap means another optimum, model or option set
CHECK_REL_TOL = 0.01
#: default stop criterion: every interval's estimated interpolation error below 0.2 % of
#: the AEP (leaves margin under the issue's 1 % against a 0.25 m/s grid)
DEFAULT_TOL = 0.002


def options_from_manifest(manifest: dict, path: Path) -> Any:
    """The sweep's ``OcpOptions`` from its manifest's ``options`` (lists back to tuples).

    Raises
    ------
    InputError
        A manifest of another schema version (an older ``bench optimize``: its layout is
        not this one's), or options that do not read.
    """
    from optimize.door import OcpOptions
    from optimize.sweep_folder import SCHEMA_VERSION

    version = manifest.get("schema_version")
    if version != SCHEMA_VERSION:
        raise InputError(path, f"a manifest of schema version {version}, written by another "
                         "version of bench optimize", column="schema_version",
                         expected=f"version {SCHEMA_VERSION}: re-run `bench optimize` with "
                                  "this version (--refine solves the sweep's own problem)")
    raw = manifest.get("options")
    if not isinstance(raw, dict):
        raise InputError(path, "no OCP options", column="options",
                         expected="the manifest of `bench optimize` (docs/schemas.md §5)")
    try:
        return OcpOptions.from_dict(raw)
    except (TypeError, ValueError) as exc:
        raise InputError(path, f"OCP options not usable: {exc}", column="options",
                         expected="a folder written by this version's `bench optimize` (re-run "
                                  "it; --refine must solve the sweep's own problem)") from exc


def system_from_manifest(manifest: dict, path: Path) -> Any:
    """The sweep's ``System`` from its manifest's ``system`` record (its own text, so the
    file may have moved), with the drive it flew in force where the manifest records it
    (the ``[drive]`` of ``sections``), or None for a sweep made before system files.

    Raises
    ------
    InputError
        The record's text does not parse or its hash differs from the record's, or its
        ``sections.drive`` is not a drive (:func:`optimize.sweep_folder.sweep_drive`).
    """
    from optimize.door import system_from_dict

    rec = manifest.get("system")
    if rec is None:
        return None
    if not isinstance(rec, dict) or not isinstance(rec.get("text"), str):
        raise InputError(path, "system record without its text", column="system",
                         expected="the manifest of `bench optimize` (docs/schemas.md §5)")
    system = system_from_dict(parse_toml(rec["text"], path, what="manifest's system text"),
                              str(rec.get("path")), rec["text"])
    if rec.get("sha256") and system.sha256 != rec["sha256"]:
        raise InputError(path, "system text does not match its recorded sha256", column="system")
    flown = sweep_drive(manifest, Path(path).parent)
    if flown is None:
        return system
    recorded = manifest["sections"]["drive"]
    return replace(system, drive=replace(system.drive, **{k: getattr(flown, k)
                                                           for k in recorded}))


def basis_figures(model: Any, trajectory: Any) -> dict:
    """``{"basis_averages": [...]}`` of a converged cycle (:func:`energy.bands.basis_averages`
    of the power model, the band's gradient), None for a failed one: the refine solves'
    extra record figure."""
    averages = None if trajectory is None else bands.basis_averages(trajectory, model).tolist()
    return {"basis_averages": averages}


@dataclass(frozen=True)
class KindTask:
    """One scenario kind's refinement (one chain of the solve service; picklable).

    Attributes
    ----------
    kind : str
    model : fitting.power_model.PowerModel
    options : optimize.problem.options.OcpOptions
    known : tuple of (float, float, float)
        The sweep's converged grid points: wind [m/s], P_elec [W], P_mech [W].
    site : Weibull or Histogram
    store : Path
        Folder of the stored solves.
    tol : float
    max_points : int
    system : optimize.system.system.System
        The sweep's system (kite, tether, winch, wind) with the drive it flew in force.
    starts : tuple of optimize.service.foreign.CycleStart
        The sweep's converged cycles of the kind (:func:`sweep_starts`): the starts of
        the check re-solve and of the added speeds nearest them.
    backend : optimize.service.builder.Backend or None
        The solver (default the CasADi OCP, :class:`optimize.service.builder.OcpBackend`);
        its results need ``success, status, start, avg_p_elec_w, avg_p_mech_w,
        period_s, trajectory`` (``weight, speed_rpm, torque_nm``) and ``warm``.
    """

    kind: str
    model: Any
    options: Any
    known: tuple[tuple[float, float, float], ...]
    site: Any
    store: Path
    tol: float = DEFAULT_TOL
    max_points: int = 25
    backend: Any = None
    system: Any = None
    starts: tuple = ()

    def chain(self, index: int = 0) -> Any:
        """The solve service's chain (:class:`optimize.service.chain.ChainTask`): no planned
        grid, a refinement of both curves from the known points, after a check re-solve."""
        from optimize.door import ChainTask, Problem, Refinement

        refine = Refinement(self.kind, self.site, refine_grid, self.tol, self.max_points,
                            self.known,
                            ("avg_p_elec_w", "avg_p_mech_w"), check=True,
                            starts=self.starts)
        return ChainTask(Problem.for_system(self.system, self.model, self.options),
                         index=index, store=self.store, backend=self.backend, refine=refine,
                         extras=partial(basis_figures, self.model))


def sweep_starts(run: OptimizeRun, points: int) -> dict[str, tuple]:
    """Kind -> the sweep's converged cycles of that kind as starts
    (:class:`optimize.service.foreign.CycleStart`, labelled ``"sweep"``), from its
    ``trajectories.parquet``; none when the folder has no such file. Only the cycles of
    ``points`` collocation points, the sweep's mesh (a cycle the last retry solved on a
    finer mesh, :mod:`optimize.service.retry`, starts nothing on this one)."""
    from optimize.door import CycleStart, Scenario
    from optimize.sweep_folder import TRAJECTORIES_FILE, read_trajectories

    if not (run.folder / TRAJECTORIES_FILE).is_file():
        return {}
    frames = {name: frame for name, frame in read_trajectories(run.folder).groupby(
        "scenario", sort=False) if len(frame) == points}
    return {kind: tuple(CycleStart(Scenario.of_kind(kind, w), "sweep", trajectory=frames[name])
                        for w, name in zip(c.wind_speed_m_s, c.scenarios, strict=True)
                        if name in frames)
            for kind, c in run.curves.items()}


def refine_kind(task: KindTask, progress: Any = None) -> list[dict]:
    """Solve the speeds the refinement asks for; returns every solve record (worker side).

    Records: those of :class:`optimize.service.solves.Solves` (stored, resumable, a
    crash reported in the record's status) with ``role`` ``"check"`` (a sweep speed
    solved again, to check the sweep's figure) or ``"added"``, plus ``basis_averages``
    (:func:`basis_figures`).
    """
    from optimize.door import run_chain

    return list(run_chain(task.chain(), progress).records)


@dataclass(frozen=True)
class KindRefinement:
    """The outcome for one kind (driver side).

    Attributes
    ----------
    kind : str
    coarse : PowerCurve
        The sweep's curve.
    records : tuple of dict
        Every solve (see :func:`refine_kind`).
    gradients : dict
        Scenario name -> basis averages of each added converged point (for the bands).
    check_note : str or None
        Set when the check re-solve failed or differed from the sweep.
    """

    kind: str
    coarse: PowerCurve
    records: tuple[dict, ...]
    gradients: dict
    check_note: str | None

    @property
    def added(self) -> tuple[dict, ...]:
        """Records of the added speeds (converged and failed)."""
        return tuple(r for r in self.records if r["role"] == "added")


def merged_curve(coarse: PowerCurve, records: tuple[dict, ...]) -> PowerCurve:
    """The sweep's curve with the converged added points in, the failed ones in ``failed``."""
    from optimize.door import scenario_name

    columns = (coarse.wind_speed_m_s, coarse.p_elec_w, coarse.p_mech_w, coarse.period_s,
               coarse.peak_speed_rpm, coarse.peak_torque_nm, coarse.scenarios)
    rows = [(float(w), float(pe), float(pm), float(t), float(n), float(q), s, False)
            for w, pe, pm, t, n, q, s in zip(*columns, strict=True)]
    have = {r[0] for r in rows}
    failed = list(coarse.failed)
    for r in records:
        w = float(r["wind_speed_m_s"])
        if r["role"] != "added" or w in have:
            continue
        if not r["success"]:
            failed.append((w, f"added by --refine: {failure_reason(r)}"))
            continue
        rows.append((w, r["avg_p_elec_w"], r["avg_p_mech_w"], r["period_s"],
                     r["peak_speed_rpm"], r["peak_torque_nm"], scenario_name(coarse.kind, w),
                     True))
    rows.sort()
    col = list(zip(*rows, strict=True))
    return replace(coarse, wind_speed_m_s=np.array(col[0]), p_elec_w=np.array(col[1]),
                   p_mech_w=np.array(col[2]), period_s=np.array(col[3]),
                   peak_speed_rpm=np.array(col[4]), peak_torque_nm=np.array(col[5]),
                   scenarios=tuple(col[6]), added=tuple(col[7]),
                   failed=tuple(sorted(failed)))


@dataclass(frozen=True)
class RefinedRun:
    """The run with refined curves, and what it took."""

    run: OptimizeRun
    kinds: dict[str, KindRefinement]
    wall_time_s: float
    executor: str
    n_solved: int
    n_loaded: int

    @property
    def gradients(self) -> dict:
        """Scenario -> basis averages of every added converged point."""
        return {s: g for k in self.kinds.values() for s, g in k.gradients.items()}


def solve_counter(desc: str, show: bool, file: Any = None) -> Any:
    """A progress bar of solves whose number is not known before they run (grids refined
    where the curve bends): it counts the solves done and their rate, and shows no share
    of a total, so it never sits at 100 % while solves still run."""
    from tqdm import tqdm

    return tqdm(total=None, unit="solve", desc=desc, disable=not show, file=file)


def refine_run(run: OptimizeRun, model: Any, site: Any, store: Path, *, tol: float = DEFAULT_TOL,
               max_points: int = 25, workers: int = 2, scheduler: str | None = None,
               show_progress: bool = True, backend: Any = None,
               call_time_limit_s: float | None = None) -> RefinedRun:
    """Refine every kind's curve of ``run`` for ``site`` (one executor task per kind).

    The solves run on the sweep's OCP options (its manifest), a solver call stopped
    after ``call_time_limit_s`` [s] when given (``--call-time-limit``), else the sweep's
    limit.

    ``backend`` replaces the CasADi OCP (see :class:`KindTask`; picklable for a process pool).

    Raises
    ------
    InputError
        ``model`` is not the sweep's (manifest hash), or the manifest has no options.
    """
    from optimize.door import attempt_line, run_chains

    manifest_path = run.folder / "manifest.json"
    if run.drive_model_sha256 and model.sha256 != run.drive_model_sha256:
        raise InputError(manifest_path, "--refine needs the power model the sweep used (its hash "
                         "differs from the manifest's drive_model.model_sha256)",
                         expected="--drive-model omitted or the sweep's own model file")
    options = options_from_manifest(run.manifest, manifest_path)
    if call_time_limit_s is not None:
        options = replace(options, solver=replace(options.solver,
                                                  call_time_limit_s=call_time_limit_s))
    system = system_from_manifest(run.manifest, manifest_path)
    mesh = options.discretization
    starts = sweep_starts(run, mesh.n_intervals * mesh.degree)
    tasks = [KindTask(k, model, options,
                      tuple(zip(c.wind_speed_m_s.tolist(), c.p_elec_w.tolist(), c.p_mech_w.tolist(),
                                strict=True)),
                      site, Path(store), tol, max_points, backend, system, starts.get(k, ()))
             for k, c in run.curves.items() if len(c.wind_speed_m_s) >= 2]
    bar = solve_counter("refine", show_progress)
    counts = {"solved": 0, "loaded": 0}

    def on_event(ev: dict) -> None:
        if "attempt" in ev:  # a solver run starts or ends: say which
            bar.set_postfix_str(attempt_line(ev))
            return
        counts["loaded" if ev["cached"] else "solved"] += 1
        bar.set_postfix_str(f"{ev['kind']} {ev['wind_speed_m_s']:g} m/s ({ev['role']}): "
                            f"{'stored' if ev['cached'] else ev['status']}")
        bar.update(1)

    t0 = time.perf_counter()
    outs, description = run_chains([t.chain(i) for i, t in enumerate(tasks)], workers=workers,
                                   scheduler=scheduler, on_event=on_event)
    bar.close()
    wall = time.perf_counter() - t0
    kinds: dict[str, KindRefinement] = {}
    curves = dict(run.curves)
    for task, out in zip(tasks, outs, strict=True):
        coarse = run.curves[task.kind]
        if out.error:  # a crashed task keeps the sweep's curve and says so
            note = f"{task.kind}: refinement failed ({out.error}); sweep grid used"
            kinds[task.kind] = KindRefinement(task.kind, coarse, (), {}, note[:400])
            continue
        records = out.records
        curve = merged_curve(coarse, records)
        names = dict(zip(curve.wind_speed_m_s.tolist(), curve.scenarios, strict=True))
        grads = {names[float(r["wind_speed_m_s"])]: np.array(r["basis_averages"])
                 for r in records if r["role"] == "added" and r["success"]}
        kinds[task.kind] = KindRefinement(task.kind, coarse, records, grads,
                                          _check_note(coarse, records))
        curves[task.kind] = curve
    return RefinedRun(replace(run, curves=curves), kinds, wall, description, counts["solved"],
                      counts["loaded"])


def _check_note(coarse: PowerCurve, records: tuple[dict, ...]) -> str | None:
    check = next((r for r in records if r["role"] == "check"), None)
    if check is None:
        return None
    w = float(check["wind_speed_m_s"])
    if not check["success"]:
        return (f"{coarse.kind}: the check re-solve at {w:g} m/s failed "
                f"({failure_reason(check)}); "
                "added points were solved without it")
    ref = float(coarse.p_elec_w[np.flatnonzero(coarse.wind_speed_m_s == w)[0]])
    gap = abs(check["avg_p_elec_w"] - ref)
    scale = float(np.max(np.abs(coarse.p_elec_w)))
    if gap > CHECK_REL_TOL * scale:
        return (f"{coarse.kind}: re-solving {w:g} m/s gave {check['avg_p_elec_w']:.1f} W, the "
                f"sweep {ref:.1f} W (gap {gap / scale:.1%} of the curve's scale): the added "
                "points may sit on another local optimum than the sweep's")
    return None


def refine_document(r: RefinedRun, site: Any, tol: float) -> dict:
    """The ``refine`` object of ``aep.json`` (docs/schemas.md §7)."""
    from energy.aep import aep_mwh

    kinds = {}
    for k, kr in r.kinds.items():
        c, m = kr.coarse, r.run.curves[k]
        kinds[k] = {
            "coarse_aep_elec_mwh": aep_mwh(c.wind_speed_m_s, c.p_elec_w, site, c.cut_in_m_s),
            "coarse_aep_mech_mwh": aep_mwh(c.wind_speed_m_s, c.p_mech_w, site),
            "aep_elec_mwh": aep_mwh(m.wind_speed_m_s, m.p_elec_w, site, m.cut_in_m_s),
            "aep_mech_mwh": aep_mwh(m.wind_speed_m_s, m.p_mech_w, site),
            "wind_speeds_m_s": m.wind_speed_m_s.tolist(),
            "solves": [{key: rec.get(key) for key in (
                "wind_speed_m_s", "role", "success", "status", "warm_from", "avg_p_elec_w",
                "avg_p_mech_w", "result_check", "wall_time_s", "cached", "store_rejected")}
                       for rec in kr.records],
            "n_added": sum(rec["success"] for rec in kr.added),
            "n_added_failed": sum(not rec["success"] for rec in kr.added),
            "note": kr.check_note,
        }
    return {"tol": tol, "wall_time_s": r.wall_time_s, "executor": r.executor,
            "n_solved": r.n_solved, "n_loaded": r.n_loaded, "store": "solves/",
            "kinds": kinds}


def added_list(kind_doc: dict) -> str:
    """``"4.75, 6.25 FAILED (Infeasible)"``: the added speeds of one kind of the document."""
    return ", ".join(f"{r['wind_speed_m_s']:g}"
                     + ("" if r["success"] else f" FAILED ({failure_reason(r)})")
                     for r in kind_doc["solves"] if r["role"] == "added") or "none"


def refine_notes(doc: dict) -> tuple[str, ...]:
    """One line per kind for ``aep.json`` ``notes`` (and the report): what was added, what
    it changed, the failures and the check re-solve's warning."""
    lines = []
    for kind, k in doc["kinds"].items():
        lines.append(
            f"{kind}: grid refined for this site (tol {doc['tol']:g}): added {added_list(k)} m/s; "
            f"AEP el {k['coarse_aep_elec_mwh']:.4f} -> {k['aep_elec_mwh']:.4f}, mech "
            f"{k['coarse_aep_mech_mwh']:.4f} -> {k['aep_mech_mwh']:.4f} MWh/yr (sweep grid -> "
            "refined)")
        if k["note"]:
            lines.append(k["note"])
        lines.extend(rejected_lines([{**r, "kind": kind} for r in k["solves"]]))
    return tuple(lines)
