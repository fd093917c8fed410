"""Ablation of the paper comparison: which model or method difference moves each statement.

Usage::

    nice -n 10 .venv/bin/python benchmarks/paper_ablation.py
        [--changes ours,intervals-100,...] [--workers 2] [--tabulate-only]
        [--fitted-model fit_out/power_model.json]
        [--out benchmarks/out/paper_ablation] [--data optimize/data/paper_ablation.json]

Every *change* re-runs the scenarios the paper's statements need (the paper's
system, its Table I drive model) with ONE difference between our OCP and the
paper's reference implementation switched to the reference's value (the public
code the paper's optimizations were run with, ghorn/rawesome,
``examples/pumping_mode/pumping_poweropt.py`` at commit 595b667 of 2013-08-30, the
first with the 7.5 kg kite); ``reference-all`` switches all of them at once.
Each run's summary goes through the claims logic
(:func:`optimize.analysis.claims.evaluate_claims`), which gives per statement
its decisive number, its margin (how far from flipping) and its verdict.

Changes (ours -> the reference's):

* ``intervals-100``: 40 -> 100 collocation intervals (degree 4 in both);
* ``period-0.5-7.5``: period bounds 1-20 s -> 0.5-7.5 s;
* ``reg-reference``: regularization scales (10, 1, 1, 1) -> (10, 0.001, 0.8, 0.1)
  (tether jerk, aileron, elevator, rudder rates; weight 0.1 W in both);
* ``tol-1e-8``: IPOPT tolerance 1e-6 -> 1e-8;
* ``reel-speed-30``: reel-speed bound 100 m/s -> 30 m/s (2865 rpm on the 0.1 m drum)
  in every kind;
* ``limit-points``: torque limit at every Radau point -> at the first and last
  Radau point of each interval, speed limit at every grid point -> at the
  interval starts only (the constrained kinds);
* ``free-first``: another start, to expose local optima: the unconstrained kinds
  start from the stored guess and the constrained ones from them (ours: the reverse);
* ``from-below``: winds 4, 5.5, 7 only, so 7 m/s is warm-started from 5.5 m/s
  (ours: from the stored guess, then 8.5 and 5.5 from 7);
* ``cold-10``: 10 m/s alone, started from the stored guess (ours: from 8.5 m/s);
* ``reference-all``: every change above except the starts, together, at the
  statements' own winds 5.5, 7 and 10 m/s only (7 warm-starts 5.5 and 10);
* ``fitted-model`` (only with ``--fitted-model PATH``): a fitted power model (e.g.
  the demo's ``bench fit`` of ``raw_measurements/``) in place of Table I.

The kite, aero, tether and wind model, the limits (1500 rpm, 78 N m), the
collocation degree, the alpha/beta/airspeed/line-angle/surface bounds and the
regularization weight are the reference's already (optimize/data/systems/highwind.toml
cites each); the coincidence tolerance is analysed without a solve (the margin).

Solves run in ``--out/<change>/`` (``summary.parquet``, ``manifest.json``);
``--tabulate-only`` re-reads them. The table (statement x change -> ours, margin,
verdict, paper) is printed as Markdown for benchmarks/README.md and written with
its command to ``--data``, the file the claims table reads its measured causes from.
"""

from __future__ import annotations

import argparse
import datetime
import functools
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from fitting.model_file import load_power_model
from kernel.files import write_json
from optimize.analysis.claims import ABLATION_PATH, evaluate_claims, load_ablation
from optimize.command import SweepRequest, run_optimize
from optimize.model import kite_model as km
from optimize.paper_model import PAPER_MODEL_PATH, paper_model
from optimize.problem.ocp import OcpOptions
from optimize.resolve import resolve
from optimize.service.builder import OcpBackend
from optimize.sweep_folder import read_summary
from optimize.sweep_options import WindGrid
from optimize.system.system_file import load_system

ROOT = Path(__file__).resolve().parent.parent
#: the statements that differ from the paper on our defaults (the ablation's subject)
STATEMENTS = ("mech-free-consumes", "elec-lim-eq-free", "mech-lim-eq-free-mech",
              "10ms-mech-peak-rpm", "10ms-peak-p-elec-gap")
KINDS = ("elec-lim", "elec-free", "mech-lim", "mech-free")
#: winds: 8.5 m/s is on the way to 10 (the sweep's continuation order 7, 8.5, 5.5, 10
#: is kept, so every scenario is reached as in `bench optimize --wind-grid 4:10:1.5`)
WINDS = (5.5, 7.0, 8.5, 10.0)
#: the reference implementation's values (rawesome pumping_poweropt.py, 595b667)
REF_INTERVALS, REF_PERIOD_S, REF_TOL = 100, (0.5, 7.5), 1e-8
REF_SIGMA = (10.0, 0.001, 0.8, 0.1)
REF_REEL_SPEED_M_S = 30.0
#: the paper's fit error: residual standard deviation 1.6 % of nominal power (section III-C)
PAPER_FIT_STD_FRACTION = 0.016


class ReferenceBackend(OcpBackend):
    """The package's OCP with the reference's reel-speed bound and limit placement.

    Parameters
    ----------
    reel_speed_m_s : float or None
        Bound on |dl/dt| in every kind [m/s] (``None``: ours).
    limit_points : bool
        Torque limit at the first and last Radau point of each interval and speed
        limit at the interval starts only, as the reference constrained them.
    """

    def __init__(self, reel_speed_m_s: float | None = None, limit_points: bool = False):
        self.reel_speed_m_s, self.limit_points = reel_speed_m_s, limit_points

    def build(self, problem):  # noqa: D102 (OcpBackend.build)
        ocp = super().build(problem)
        ocp.bounds = functools.partial(reference_bounds, ocp, type(ocp).bounds.__get__(ocp),
                                       self.reel_speed_m_s, self.limit_points)
        return ocp


def reference_bounds(ocp, base, reel_speed_m_s, limit_points, drive_limits, fix_fictitious,
                     period_s):
    """``ocp.bounds`` with the reference's reel-speed bound and limit points."""
    lbw, ubw, lbg, ubg = base(drive_limits, fix_fictitious, period_s)
    lay, tr = ocp.layout, ocp.transcription
    idx = lay.i_x[km.STATES.index("dl_m_s")]
    scale = ocp.scales.state[km.STATES.index("dl_m_s")]
    if limit_points and drive_limits:
        d = ocp.coll.degree
        inner = idx[np.arange(lay.n_points) % d != 0]  # grid points other than interval starts
        lbw[inner], ubw[inner] = tr.lbw[inner], tr.ubw[inner]
        rows = lay.rows_of("torque").reshape(-1, d)[:, 1 : d - 1]  # Radau points 2..d-1
        ubg[rows.ravel()] = np.inf
    if reel_speed_m_s is not None:
        lbw[idx] = np.maximum(lbw[idx], -reel_speed_m_s / scale)
        ubw[idx] = np.minimum(ubw[idx], reel_speed_m_s / scale)
    return lbw, ubw, lbg, ubg


@dataclass(frozen=True)
class Change:
    """One ablation run: what differs from ours, and how it is run."""

    name: str
    what: str  # "ours -> the reference's", in words
    options: dict = field(default_factory=dict)  # OcpOptions groups: {group: {field: value}}
    period_bounds_s: tuple[float, float] | None = None  # the system's [bounds] period range
    reel_speed_m_s: float | None = None
    limit_points: bool = False
    winds: tuple[float, ...] = WINDS
    kinds: tuple[str, ...] = KINDS
    fitted_model: bool = False  # the --fitted-model in place of Table I


CHANGES = (
    Change("ours", "our defaults (40 intervals, period 1-20 s, sigma (10, 1, 1, 1), tol 1e-6, "
           "|dl/dt| <= 100 m/s, limits at every collocation point)"),
    Change("period-0.5-7.5", "period bounds 1-20 s -> the reference's 0.5-7.5 s",
           period_bounds_s=REF_PERIOD_S),
    Change("reg-reference", "regularization scales (10, 1, 1, 1) -> the reference's "
           "(10, 0.001, 0.8, 0.1)", {"discretization": {"control_sigma": REF_SIGMA}}),
    Change("tol-1e-8", "IPOPT tolerance 1e-6 -> the reference's 1e-8",
           {"solver": {"tol": REF_TOL}}),
    Change("reel-speed-30", "reel-speed bound 100 m/s -> the reference's 30 m/s (2865 rpm)",
           reel_speed_m_s=REF_REEL_SPEED_M_S),
    Change("limit-points", "drive limits at every collocation point -> the reference's "
           "(torque at 2 of 4 Radau points, speed at interval starts)", limit_points=True),
    Change("free-first", "another start: unconstrained kinds from the stored guess, "
           "constrained kinds from them", kinds=("elec-free", "elec-lim", "mech-free",
                                                  "mech-lim")),
    Change("from-below", "another start: 7 m/s warm-started from 5.5 m/s",
           winds=(4.0, 5.5, 7.0)),
    Change("cold-10", "another start: 10 m/s from the stored guess", winds=(10.0,),
           kinds=("elec-free", "mech-free")),
    Change("intervals-100", "40 -> the reference's 100 collocation intervals",
           {"discretization": {"n_intervals": REF_INTERVALS}}),
    Change("reference-all", "all of the reference's settings above together",
           {"discretization": {"n_intervals": REF_INTERVALS, "control_sigma": REF_SIGMA},
            "solver": {"tol": REF_TOL}}, period_bounds_s=REF_PERIOD_S,
           reel_speed_m_s=REF_REEL_SPEED_M_S, limit_points=True,
           winds=(5.5, 7.0, 10.0)),  # the statements' winds only: 100 intervals cost
    Change("fitted-model", "the paper's Table I model -> the fitted model of --fitted-model "
           "(the demo's bench fit of raw_measurements/)",
           fitted_model=True),
)


def run_change(change: Change, out: Path, workers: int, fitted: Path | None) -> dict:
    """Solve the change's scenarios into ``out/<name>``; return its run record."""
    system = load_system()
    if change.period_bounds_s is not None:  # a change of the system's bounds
        lo, hi = change.period_bounds_s
        system = replace(system, bounds=replace(system.bounds, period_min_s=lo, period_max_s=hi))
    path = fitted if change.fitted_model else PAPER_MODEL_PATH
    model = load_power_model(path) if change.fitted_model else paper_model()
    options = OcpOptions().replace(**change.options)
    request = SweepRequest(WindGrid(change.winds, change.kinds),
                           resolve(system, model, options=options, model_path=path),
                           f"paper ablation: {change.name}", workers=workers,
                           out=out / change.name, claims=False)
    backend = (ReferenceBackend(change.reel_speed_m_s, change.limit_points)
               if change.reel_speed_m_s is not None or change.limit_points else None)
    load0, c0, t0 = os.getloadavg()[0], time.process_time(), time.perf_counter()
    outcome = run_optimize(request, command_line=sys.argv, show_progress=False,
                           backend=backend)
    check_in_force(change, json.loads((out / change.name / "manifest.json").read_text()))
    s = outcome.summary
    record = {"change": change.name, "wall_time_s": time.perf_counter() - t0,
              "driver_cpu_s": time.process_time() - c0, "load_1min_start": load0,
              "load_1min_end": os.getloadavg()[0], "converged": int(s["success"].sum()),
              "scenarios": len(s), "iterations": int(s["iterations"].sum()),
              "failed": s.loc[~s["success"], "scenario"].tolist()}
    print(json.dumps(record), flush=True)
    return record


def check_in_force(change: Change, manifest: dict) -> None:
    """Stop if the sweep did not run with the change (e.g. a system value overrode it)."""
    wanted = {("options", g, k): v for g, fields in change.options.items()
              for k, v in fields.items()}
    if change.period_bounds_s is not None:
        wanted["bound_values", None, "period_min"] = change.period_bounds_s[0]
        wanted["bound_values", None, "period_max"] = change.period_bounds_s[1]
    for (record, group, key), value in wanted.items():
        got = manifest[record][group][key] if group else manifest[record][key]
        if not np.allclose(np.asarray(got, dtype=float), np.asarray(value, dtype=float)):
            raise RuntimeError(f"{change.name}: {record} {key} in force is {got}, not {value}")


def tabulate(changes: tuple[Change, ...], out: Path) -> dict:
    """Claims of every change's run: statement -> change -> value, margin, verdict, ours."""
    def claims_of(summary: pd.DataFrame) -> pd.DataFrame:
        return evaluate_claims(summary, pd.DataFrame(), paper_system=True,
                               ablation={}).set_index("claim_id")

    table: dict = {}
    base_path = out / "ours" / "summary.parquet"
    if not base_path.exists():
        return table
    base = read_summary(base_path)
    full = claims_of(base)
    for change in changes:
        path = out / change.name / "summary.parquet"
        if not path.exists():
            continue
        claims = claims_of(read_summary(path))
        # ours on this change's winds: where it differs from ours on all winds, the
        # change misses the wind speed that decides the statement
        same_winds = claims_of(base[base["wind_speed_m_s"].isin(change.winds)])
        for r in claims.reset_index().itertuples(index=False):
            row = table.setdefault(r.claim_id, {"statement": r.statement, "paper": r.paper,
                                                "unit": r.unit, "changes": {}})
            if r.verdict == "not comparable" or not np.isclose(
                    same_winds.loc[r.claim_id, "value"], full.loc[r.claim_id, "value"],
                    rtol=1e-9, atol=1e-9):
                continue  # this change's winds or kinds do not cover the statement
            row["changes"][change.name] = {"value": r.value, "margin": r.margin,
                                           "tolerance": r.tolerance, "verdict": r.verdict,
                                           "ours": r.ours}
    for cid, notes in paper_notes(table).items():
        table[cid]["paper_notes"] = notes
    return table


def paper_notes(table: dict) -> dict[str, list[str]]:
    """The paper's own numbers that bound a statement: its reference implementation's reel
    speed bound (peak speed) and its drive model's stated error (a small net power)."""
    notes = {}
    drum_m = load_system().winch.drum_radius_m
    cap_rpm = REF_REEL_SPEED_M_S / drum_m * 60.0 / (2.0 * np.pi)
    if "10ms-mech-peak-rpm" in table:
        notes["10ms-mech-peak-rpm"] = [
            f"the paper's 3300 rpm is above the {cap_rpm:.0f} rpm its reference implementation "
            f"allows (reel speed <= {REF_REEL_SPEED_M_S:g} m/s on the {drum_m:g} m drum)"]
    ours = table.get("mech-free-consumes", {}).get("changes", {}).get("ours")
    if ours is not None:
        fit_std_w = PAPER_FIT_STD_FRACTION * paper_model().nominal_power_w
        notes["mech-free-consumes"] = [
            f"the paper's Table I fit has a residual standard deviation of {fit_std_w:.0f} W "
            f"({PAPER_FIT_STD_FRACTION:.1%} of nominal power, section III-C), "
            f"{fit_std_w / abs(ours['value']):.1f} times the {abs(ours['value']):.1f} W net "
            "power that decides the sign"]
    return notes


def paper_checks() -> list[str]:
    """The paper against its own numbers: Table I at the drive limits, its two 10 m/s periods."""
    model = paper_model()
    speed_limit, torque = model.drive.box()  # the paper's nominal torque
    lines = []
    for what, p_mech in (("full load", model.nominal_power_w),
                         ("the limits' corner", speed_limit * torque * 2.0 * np.pi / 60.0)):
        speed = p_mech / torque * 60.0 / (2.0 * np.pi)
        eta_mot = p_mech / float(model.p_elec_w(speed, torque))
        eta_gen = -float(model.p_elec_w(-speed, torque)) / p_mech
        lines.append(f"Table I at {what} ({p_mech:.0f} W shaft power: {torque:g} N m, "
                     f"{speed:.0f} rpm): motor efficiency {eta_mot:.3f}, generator "
                     f"{eta_gen:.3f}, where section III-A gives 91 % at full load")
    period_fig9, period_text = 2.14, 2.2  # Fig. 9 caption and section V-B
    return [
        *lines,
        f"the 10 m/s mechanically optimized unconstrained cycle lasts {period_fig9:g} s in the "
        f"caption of Fig. 9 and {period_text:g} s in section V-B "
        f"({(period_text - period_fig9) / period_fig9:+.1%})",
    ]


def markdown(table: dict, changes: tuple[Change, ...]) -> str:
    """The README table: statement x change -> ours, margin, verdict (paper per statement)."""
    lines = ["| statement (paper) | change | ours | margin | verdict |", "|---|---|---|---|---|"]
    for cid in STATEMENTS:
        row = table.get(cid)
        if row is None:
            continue
        base = row["changes"].get("ours", {}).get("value", np.nan)
        for change in changes:
            c = row["changes"].get(change.name)
            if c is None:
                continue
            delta = c["value"] - base
            move = ("" if change.name == "ours" else " (±0)"
                    if abs(delta) < 5e-4 * max(1.0, abs(base)) else f" ({delta:+.3g})")
            lines.append(f"| `{cid}` ({row['paper']}) | {change.name} | {c['value']:.4g} "
                         f"{row['unit']}{move} | {c['margin']:+.3g} {row['unit']} | "
                         f"{c['verdict']} |")
        ours = row["changes"].get("ours")
        if ours and np.isfinite(ours.get("tolerance", np.nan)):
            flip = ours["tolerance"] - ours["margin"]
            lines.append(f"| `{cid}` | tolerance (no solve) | {ours['tolerance']:.4g} "
                         f"{row['unit']} in force | flips at a tolerance of {flip:.4g} "
                         f"{row['unit']} | - |")
    return "\n".join(lines)


def _commit() -> str:
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], check=True,
                              capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--changes", default=",".join(c.name for c in CHANGES))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "paper_ablation")
    ap.add_argument("--data", type=Path, default=ABLATION_PATH)
    ap.add_argument("--tabulate-only", action="store_true")
    ap.add_argument("--fitted-model", type=Path, default=None,
                    help="power_model.json of bench fit, for the fitted-model change")
    args = ap.parse_args()
    by_name = {c.name: c for c in CHANGES}
    unknown = [n for n in args.changes.split(",") if n not in by_name]
    if unknown:
        ap.error(f"unknown change {unknown[0]!r}; known: {', '.join(by_name)}")
    chosen = tuple(by_name[n] for n in args.changes.split(",")
                   if not by_name[n].fitted_model or args.fitted_model is not None)
    previous = load_ablation(args.data) or {}
    runs = {r["change"]: r for r in previous.get("runs", [])}
    if not args.tabulate_only:
        for change in chosen:
            runs[change.name] = run_change(change, args.out, args.workers, args.fitted_model)
    table = tabulate(CHANGES, args.out)
    print(markdown(table, CHANGES))
    print("\n".join(paper_checks()))
    data = {
        "source": "benchmarks/paper_ablation.py",
        "command": "nice -n 10 .venv/bin/python benchmarks/paper_ablation.py "
        "--fitted-model fit_out/power_model.json (fit_out from bench ingest raw_measurements; "
        "bench fit)",
        "last_invocation": sys.argv,
        "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "commit": _commit(),
        "baseline": "ours",
        "changes": {c.name: c.what for c in CHANGES},
        "runs": list(runs.values()),
        "statements": table,
        "paper_checks": paper_checks(),
    }
    write_json(args.data, data, indent=2)
    print(f"wrote {args.data}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
