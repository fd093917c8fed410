"""AP2 against awebox, one change at a time: which bound or model part moves power and period.

Usage::

    nice -n 10 .venv/bin/python benchmarks/ap2_ablation.py [--steps today,line-40,...]
        [--workers 2] [--curve] [--tabulate-only] [--out benchmarks/out/ap2_ablation]

Every *step* runs ``bench optimize --system STEP.toml --wind-grid 10 --scenarios
mech-free --no-claims`` (the AP2 example of awebox: 10 m/s at 100 m, power law 0.15) in a
scratch folder with no ``fit_out/``, on a copy of the shipped
``optimize/data/systems/ap2.toml`` with the changes up to that step and none after it:

* ``today``: the file before awebox's remaining settings were expressible (drivebench
  170ba8d): line angle 65 deg, no reel-speed, body-rate or tension-floor bound, constant
  density, lumped massless tether, and lift and drag fitted to awebox's force
  coefficients (CL linear and CD quadratic, least squares over 61 points of the alpha
  range) with the other derivatives at alpha = 0 and those the model lacked left out;
  the fit is recomputed here from the shipped polynomials;
* ``line-40``: the line angle of 40 deg (awebox's ``rot_angles[2]``);
* ``reel-speed``: reel speed within [-15, 20] m/s in every kind;
* ``body-rates``: body rates within 50 deg/s;
* ``tension-50``: tension at least 50 N;
* ``isa``: the ISA atmosphere;
* ``aero-poly``: every derivative the model had as awebox's polynomial in alpha;
* ``aero-more``: the derivatives it lacked (CL_q, CD_q, CY_p, CY_r, CY_deltaa, Cl_deltar,
  Cn_deltaa);
* ``drag-5``: tether drag over 5 elements with their own apparent wind;
* ``mass``: the tether's mass, 0.0046 kg/m;
* ``surfaces-30``: elevator and rudder within 30 deg (the aileron 20): the shipped file.

Variants of the shipped file measure awebox's remaining differences and the local optima
instead of copying them (``--variants``):

* ``ends-only``: the path constraints (airspeed, alpha, beta, line angle, tether force)
  at the last Radau point of each interval only, the interval ends: awebox imposes them
  at the interval starts only, so a cycle may break them in between;
* ``from-P`` for each ``--free-from`` period P (default awebox's 51.6 s): solved with the
  period held at P (a cold start), then again with it free: the local optimum nearest P.

``ends-only`` solves the shipped file as always, then again from its optimum with the
rows relaxed between the interval ends. ``--hold-periods 40,51.6,...`` flies the
shipped file with its period held at each (bounds P +- 0.1 s): the power along the
period, at awebox's 51.6 s among them.

Each row: status, average mechanical power, period, the largest line angle, reel speeds,
the body rates and the bounds the optimum sits on, against the paper (Licitra et al.
2019: 4.4 kW, 39.6 s) and awebox as it ships (4.88 kW, 51.6 s, issue 39). ``--curve``
also flies the shipped file over 6-14 m/s (mech-free and elec-lim). Prints the Markdown
tables for benchmarks/README.md and writes ``--out/ap2_ablation.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from optimize.command import make_request, run_optimize
from optimize.model.aero import at_alpha
from optimize.service.builder import OcpBackend
from optimize.sweep_options import Execution, WindGrid
from optimize.system.system_file import system_from_dict

ROOT = Path(__file__).resolve().parent.parent
BENCH = Path(sys.executable).parent / "bench"
AP2 = ROOT / "optimize" / "data" / "systems" / "ap2.toml"
#: the references: Licitra et al., Energy 173 (2019); awebox 03adf950 as it ships (issue 39)
PAPER = (4400.0, 39.6)
AWEBOX = (4880.0, 51.6)
#: the derivatives the model lacked before (their keys are optional, 0 = absent)
ADDED = ("cl_q", "cd_q", "cy_p", "cy_r", "cy_ail", "cl_rud", "cn_ail")


def linear_fit_aero(aero: dict) -> dict:
    """``[aero]`` as the file had it before polynomials: CL linear and CD quadratic fitted
    over 61 points of the alpha range, the other derivatives at alpha = 0 (the alpha
    term of Cl_beta and Cn_beta as ``*_alpha_beta``), the added ones absent."""
    alpha = np.radians(np.linspace(aero["alpha_min_deg"], aero["alpha_max_deg"], 61))
    poly = {k: tuple(v) if isinstance(v, list) else v for k, v in aero.items()}
    cl = at_alpha(poly["cl0"], alpha) + at_alpha(poly["cl_alpha"], alpha) * alpha
    cd = (at_alpha(poly["cd0"], alpha) + at_alpha(poly["cd_alpha"], alpha) * alpha
          + at_alpha(poly["cd_alpha2"], alpha) * alpha**2)
    cl1, cl0 = np.polyfit(alpha, cl, 1)
    cd2, cd1, cd0 = np.polyfit(alpha, cd, 2)
    out = {k: v for k, v in aero.items() if k not in ADDED}
    out.update(cl0=float(cl0), cl_alpha=float(cl1), cd0=float(cd0), cd_alpha=float(cd1),
               cd_alpha2=float(cd2))
    for key, value in aero.items():
        if isinstance(value, list) and key not in ("cl0", "cd0") and key not in ADDED:
            out[key] = value[0]
    out["cl_alpha_beta"], out["cn_alpha_beta"] = aero["cl_beta"][1], aero["cn_beta"][1]
    return out


def _drop(section: str, *keys: str) -> Callable[[dict, dict], None]:
    """A step that adds the shipped file's ``keys`` of ``section`` back."""
    def step(data: dict, shipped: dict) -> None:
        for key in keys:
            data[section][key] = shipped[section][key]
    return step


def _aero_poly(data: dict, shipped: dict) -> None:
    data["aero"] = {k: v for k, v in shipped["aero"].items() if k not in ADDED}


STEPS: tuple[tuple[str, str, Callable[[dict, dict], None] | None], ...] = (
    ("today", "the file of drivebench 170ba8d", None),
    ("line-40", "line angle 65 -> 40 deg", _drop("bounds", "max_line_angle_deg")),
    ("reel-speed", "reel speed within [-15, 20] m/s",
     _drop("winch", "max_reel_out_speed_m_s", "max_reel_in_speed_m_s")),
    ("body-rates", "body rates within 50 deg/s", _drop("bounds", "max_body_rate_deg_s")),
    ("tension-50", "tension >= 50 N", _drop("bounds", "min_tension_n")),
    ("isa", "ISA atmosphere", _drop("wind", "atmosphere")),
    ("aero-poly", "derivatives as polynomials in alpha", _aero_poly),
    ("aero-more", "+ CL_q, CD_q, CY_p, CY_r, CY_da, Cl_dr, Cn_da", _drop("aero", *ADDED)),
    ("drag-5", "tether drag over 5 elements", _drop("tether", "drag_elements")),
    ("mass", "tether mass 0.0046 kg/m", _drop("tether", "mass_kg_m")),
    ("surfaces-30", "elevator and rudder within 30 deg (the shipped file)",
     _drop("bounds", "elevator_max_deg", "rudder_max_deg")),
)


def today(shipped: dict) -> dict:
    """The shipped file without every step's change."""
    data = json.loads(json.dumps(shipped))
    data["bounds"]["max_line_angle_deg"] = 65.0
    for section, key in (("winch", "max_reel_out_speed_m_s"), ("winch", "max_reel_in_speed_m_s"),
                         ("bounds", "max_body_rate_deg_s"), ("bounds", "min_tension_n"),
                         ("wind", "atmosphere"), ("tether", "drag_elements"),
                         ("tether", "mass_kg_m"), ("bounds", "elevator_max_deg"),
                         ("bounds", "rudder_max_deg")):
        data[section].pop(key)
    data["aero"] = linear_fit_aero(shipped["aero"])
    return data


def step_files() -> dict[str, dict]:
    """Each step's system (cumulative)."""
    shipped = tomllib.loads(AP2.read_text())
    data, out = today(shipped), {}
    for name, _, change in STEPS:
        if change is not None:
            change(data, shipped)
        out[name] = json.loads(json.dumps(data))
    assert out[STEPS[-1][0]] == shipped, "the last step is not the shipped file"
    return out


def to_toml(data: dict) -> str:
    """A system file's text (sections of numbers, strings, booleans and number lists)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)
    return "\n".join(f"[{section}]\n" + "".join(f"{k} = {value(v)}\n" for k, v in body.items())
                     for section, body in data.items())


def run(name: str, data: dict, out: Path, grid: str, kinds: str) -> dict:
    """``bench optimize`` on one step's file in a folder with no fit_out/."""
    (out / f"{name}.toml").write_text(to_toml(data))
    with tempfile.TemporaryDirectory() as cwd:
        t0 = time.perf_counter()
        proc = subprocess.run([str(BENCH), "optimize", "--system", str(out / f"{name}.toml"),
                               "--wind-grid", grid, "--scenarios", kinds, "--no-claims",
                               "--workers", "1", "--out", str(out / name)],
                              cwd=cwd, capture_output=True, text=True)
    (out / f"{name}.log").write_text(proc.stdout + proc.stderr)
    return {"exit": proc.returncode, "wall_s": time.perf_counter() - t0}


#: the rows awebox imposes at the interval starts only (its model_bounds)
PATH_ROWS = ("airspeed", "alpha", "beta", "line_angle", "torque", "tether_force")


class StagedBackend(OcpBackend):
    """The package's OCP solved in two stages: the cold start as always (or with the
    period held at ``hold_period_s``), then, warm-started from it, with the period free
    and (``ends_only``) the path rows at each interval's last Radau point only."""

    def __init__(self, ends_only: bool = False, hold_period_s: float | None = None):
        self.ends_only, self.hold_period_s, self.stage = ends_only, hold_period_s, 1

    def build(self, problem):  # noqa: D102 (OcpBackend.build)
        ocp = super().build(problem)
        base = type(ocp).bounds.__get__(ocp)

        def bounds(drive_limits, fix_fictitious, period_s):
            if self.stage == 1 and self.hold_period_s is not None:
                period_s = self.hold_period_s
            lbw, ubw, lbg, ubg = base(drive_limits, fix_fictitious, period_s)
            if self.stage == 2 and self.ends_only:
                d = ocp.coll.degree
                for name in PATH_ROWS:
                    rows = ocp.layout.rows_of(name)
                    if rows.size:
                        inner = rows.reshape(ocp.n_intervals, d)[:, : d - 1].ravel()
                        lbg[inner], ubg[inner] = -np.inf, np.inf
            return lbw, ubw, lbg, ubg

        ocp.bounds = bounds
        return ocp

    def cold_start(self, ocp, scenario):  # noqa: D102 (OcpBackend.cold_start)
        self.stage = 1
        first = super().cold_start(ocp, scenario)
        if not first.success:
            return first
        self.stage = 2
        return self.solve(ocp, scenario, first.warm)


def run_staged(name: str, data: dict, out: Path, backend: StagedBackend) -> dict:
    """The shipped file with a :class:`StagedBackend`, at 10 m/s mech-free, in-process."""
    system = system_from_dict(data, str(AP2))
    request = make_request(WindGrid((10.0,), ("mech-free",)), system=system,
                           out=out / name, execution=Execution(workers=1), claims=False)
    t0 = time.perf_counter()
    run_optimize(request, command_line=sys.argv, show_progress=False, backend=backend)
    return {"exit": 0, "wall_s": time.perf_counter() - t0}


def measure(folder: Path) -> list[dict]:
    """Per scenario of a run: power, period, extremes and active bounds."""
    s = pd.read_parquet(folder / "summary.parquet")
    t = pd.read_parquet(folder / "trajectories.parquet")
    rows = []
    for r in s.itertuples(index=False):
        tr = t[t.scenario == r.scenario]
        rates = np.degrees(tr[["omega_x_rad_s", "omega_y_rad_s", "omega_z_rad_s"]].abs())
        rows.append({"scenario": r.scenario, "status": r.status, "success": bool(r.success),
                     "p_mech_w": float(r.avg_p_mech_w), "p_elec_w": float(r.avg_p_elec_w),
                     "period_s": float(r.period_s),
                     "line_angle_max_deg": float(tr.line_angle_deg.max()),
                     "reel_speed_m_s": [float(tr.dl_m_s.min()), float(tr.dl_m_s.max())],
                     "body_rate_max_deg_s": float(rates.to_numpy().max()),
                     "tension_min_n": float(tr.tension_n.min()),
                     "tether_length_m": [float(tr.l_m.min()), float(tr.l_m.max())],
                     "active_bounds": r.active_bounds})
    return rows


def ablation_table(results: dict) -> str:
    lines = ["| step | change | status | P_mech [kW] | vs paper | vs awebox | period [s] | "
             "vs paper | vs awebox | max line angle [deg] | reel speed [m/s] | "
             "max body rate [deg/s] | active bounds |", "|---|---|---|" + "---:|" * 9 + "---|"]
    def held(prefix: str) -> list[str]:
        return sorted((n for n in results if n.startswith(prefix)),
                      key=lambda n: float(n[len(prefix):]))

    variants = [("ends-only", "shipped file, then path rows at interval ends only"),
                *((n, f"shipped file, period free from its optimum held at {n[5:]} s")
                  for n in held("from-")),
                *((n, f"shipped file, period held at {n[7:]} s") for n in held("period-"))]
    for name, what in [(n, w) for n, w, _ in STEPS] + variants:
        for r in results.get(name, []):
            p, t = -r["p_mech_w"], r["period_s"]
            lo, hi = r["reel_speed_m_s"]
            lines.append(
                f"| {name} | {what} | {r['status']} | {p / 1e3:.2f} | "
                f"{p / PAPER[0] - 1:+.1%} | {p / AWEBOX[0] - 1:+.1%} | {t:.1f} | "
                f"{t / PAPER[1] - 1:+.1%} | {t / AWEBOX[1] - 1:+.1%} | "
                f"{r['line_angle_max_deg']:.1f} | {lo:.1f} to {hi:.1f} | "
                f"{r['body_rate_max_deg_s']:.0f} | {r['active_bounds'] or '-'} |")
    return "\n".join(lines)


def curve_table(rows: list[dict]) -> str:
    lines = ["| scenario | status | P_mech [kW] | P_elec [kW] | period [s] | active bounds |",
             "|---|---|---:|---:|---:|---|"]
    for r in sorted(rows, key=lambda r: (r["scenario"].rsplit("-", 1)[0],
                                         float(r["scenario"].rsplit("-", 1)[1]))):
        lines.append(f"| {r['scenario']} | {r['status']} | {-r['p_mech_w'] / 1e3:.2f} | "
                     f"{-r['p_elec_w'] / 1e3:.2f} | {r['period_s']:.1f} | "
                     f"{r['active_bounds'] or '-'} |")
    return "\n".join(lines)


def staged(free_from: list[float]) -> list[tuple[str, StagedBackend]]:
    """The in-process variants: ends-only, and the period freed from each held period."""
    return [("ends-only", StagedBackend(ends_only=True)),
            *((f"from-{p:g}", StagedBackend(hold_period_s=p)) for p in free_from)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", default=",".join(s[0] for s in STEPS))
    ap.add_argument("--workers", type=int, default=2, help="steps run side by side")
    ap.add_argument("--curve", action="store_true", help="also the power curve 6-14 m/s")
    ap.add_argument("--variants", action="store_true",
                    help="also ends-only and the period freed from each --free-from period")
    ap.add_argument("--free-from", default="51.6",
                    help="periods [s] to hold (a cold start), then free, with --variants")
    ap.add_argument("--hold-periods", default="",
                    help="periods [s] to hold the shipped file at, e.g. 40,45,51.6,60,70")
    ap.add_argument("--tabulate-only", action="store_true")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "ap2_ablation")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    variants = staged([float(p) for p in args.free_from.split(",") if p]) \
        if args.variants else []
    files = step_files()
    names = [n for n in args.steps.split(",") if n]
    jobs = [(n, files[n], "10", "mech-free") for n in names]
    shipped = files[STEPS[-1][0]]
    if args.curve:
        jobs.append(("curve", shipped, "6:14:2", "mech-free,elec-lim"))
    for p in [float(p) for p in args.hold_periods.split(",") if p]:
        held = json.loads(json.dumps(shipped))
        held["bounds"].update(period_min_s=p - 0.1, period_max_s=p + 0.1)
        jobs.append((f"period-{p:g}", held, "10", "mech-free"))
    if not args.tabulate_only:
        with ThreadPoolExecutor(args.workers) as pool:
            for (name, *_), info in zip(jobs, pool.map(lambda j: run(*j[:2], args.out, *j[2:]),
                                                       jobs), strict=True):
                print(f"{name}: exit {info['exit']}, {info['wall_s']:.0f} s "
                      f"(load {os.getloadavg()[0]:.1f})", flush=True)
        for name, backend in variants:
            info = run_staged(name, shipped, args.out, backend)
            print(f"{name}: {info['wall_s']:.0f} s (load {os.getloadavg()[0]:.1f})")
    names = [n for n, *_ in jobs] + [n for n, _ in variants]
    results = {n: measure(args.out / n) for n in names
               if (args.out / n / "summary.parquet").exists()}
    print(ablation_table(results))
    if "curve" in results:
        print(curve_table(results["curve"]))
    (args.out / "ap2_ablation.json").write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
