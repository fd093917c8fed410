"""What the drivetrain changes: inertia, reel-acceleration limit and envelope, measured.

Usage::

    .venv/bin/python benchmarks/drivetrain_effect.py [--cases paper-0,paper,paper-2x,ap2,megawes]
        [--wind-grid 4:10:1.5] [--reference DIR] [--from DIR] [--claims]

Every case is ``bench optimize --system FILE --wind-grid GRID --no-claims`` in a scratch
folder with no ``fit_out/`` (so the system's own ``[drive]`` is in force), timed:

* ``paper-0``: the shipped ``highwind.toml`` with its drivetrain keys removed (a
  massless drum, no acceleration limit): the OCP before the drivetrain. With
  ``--reference DIR`` (an ``optimize_out/`` of that OCP) its optima are compared: the
  largest |dP| [W] per scenario.
* ``paper``: the shipped ``highwind_drivetrain.toml`` (``highwind.toml`` with the
  estimate of its drum's and rotor's inertia); ``paper-2x``: twice it.
* ``ap2``, ``megawes``: the shipped files, ``mech-free`` and ``elec-lim`` only.
* ``ap2-awebox``: ``ap2.toml`` at 10 m/s, ``mech-free``, against awebox's AP2 example
  (Licitra et al., Energy 173, 2019, circular trajectory at 10 m/s: 4.4 kW, 39.6 s;
  awebox ``examples/ampyx_ap2_trajectory.py``, tolerance 20 % in
  ``test/reg/test_examples.py``), and the same with one change at a time undone
  (``--ablate``): no acceleration limit, no inertia, the old log-law wind, the old
  2 s period floor, the old 10 m ground clearance.

Per case and scenario: status, P_elec, P_mech [W], period [s], the largest |reel
acceleration| [m/s^2], the largest |shaft torque| and |tether torque| at the motor
[N m], the largest shaft torque over the envelope in force (1 = on it), the active
bounds, and the sweep's wall time. With ``--claims`` the paper cases also compare
themselves with the paper's claims (``claims.csv``), printed side by side: which of
the paper's statements the drivetrain moves. Writes
``benchmarks/out/drivetrain_effect.json`` and prints Markdown tables.
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
from pathlib import Path

import numpy as np
import pandas as pd

from bench.synth.writers import toml_document
from kernel.drive import Drive
from optimize.model.envelope import envelope_torque_nm
from optimize.sweep_folder import CLAIMS_FILE, read_claims

ROOT = Path(__file__).resolve().parent.parent
SYSTEMS = ROOT / "optimize" / "data" / "systems"
OUT = ROOT / "benchmarks" / "out"
#: awebox's AP2 example (Licitra et al. 2019, Figs. 10 and 11) and its test tolerance
AWEBOX_AP2 = {"p_mech_w": -4400.0, "period_s": 39.6, "rtol": 0.2}
DRIVETRAIN_KEYS = {"winch": ("drum_inertia_kg_m2", "max_reel_acceleration_m_s2"),
                   "drive": ("rotor_inertia_kg_m2", "base_speed_rpm", "envelope_speed_rpm",
                             "envelope_torque_nm")}


def _load(name: str) -> dict:
    return tomllib.loads((SYSTEMS / f"{name}.toml").read_text())


def _massless(data: dict) -> dict:
    for section, keys in DRIVETRAIN_KEYS.items():
        for key in keys:
            data[section].pop(key, None)
    return data


def _estimated_highwind(factor: float) -> dict:
    """``highwind_drivetrain.toml`` (the paper's system with its estimated inertia), the
    inertia times ``factor``."""
    data = _load("highwind_drivetrain")
    data["winch"]["drum_inertia_kg_m2"] *= factor
    data["drive"]["rotor_inertia_kg_m2"] *= factor
    return data


def _ablations() -> dict[str, dict]:
    """``ap2.toml`` with one of its awebox bounds (or its drivetrain) undone at a time."""
    out = {"ap2-awebox": _load("ap2")}
    data = _load("ap2")
    data["winch"].pop("max_reel_acceleration_m_s2")
    out["ap2-awebox-no-acceleration-limit"] = data
    out["ap2-awebox-massless"] = _massless(_load("ap2"))
    data = _load("ap2")
    data["wind"] = {**{k: v for k, v in data["wind"].items() if k != "exponent"},
                    "profile": "log", "roughness_length_m": 0.1}
    out["ap2-awebox-log-wind"] = data
    data = _load("ap2")
    data["bounds"]["period_min_s"] = 2.0
    out["ap2-awebox-period-2s"] = data
    data = _load("ap2")
    data["bounds"]["min_ground_clearance_m"] = 10.0
    out["ap2-awebox-clearance-10m"] = data
    return out


def cases(ablate: bool) -> dict[str, tuple[dict, str, str]]:
    """Case name -> (system data, wind grid or None for the default, scenario kinds)."""
    paper = "elec-lim,elec-free,mech-lim,mech-free"
    out = {
        "paper-0": (_massless(_load("highwind")), None, paper),
        "paper": (_estimated_highwind(1.0), None, paper),
        "paper-2x": (_estimated_highwind(2.0), None, paper),
        "ap2": (_load("ap2"), "6,10", "elec-lim,mech-free"),
        "megawes": (_load("megawes"), "8,12", "elec-lim,mech-free"),
    }
    awebox = _ablations() if ablate else {"ap2-awebox": _load("ap2")}
    out.update({name: (data, "10", "mech-free") for name, data in awebox.items()})
    return out


def run_case(name: str, data: dict, grid: str | None, kinds: str, folder: Path,
             claims: bool = False) -> dict:
    """``bench optimize`` on one system (written next to the output) in a clean folder
    (with the comparison with the paper's claims when ``claims``)."""
    system = folder / f"{name}.toml"
    system.write_text(toml_document({}, data))
    args = [sys.executable, "-m", "drivebench.cli", "optimize", "--system", str(system),
            "--scenarios", kinds, "--out", str(folder / name)] + ([] if claims
                                                                  else ["--no-claims"])
    if grid is not None:
        args += ["--wind-grid", grid]
    with tempfile.TemporaryDirectory() as cwd:
        t0 = time.perf_counter()
        proc = subprocess.run(args, cwd=cwd, capture_output=True, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
        wall = time.perf_counter() - t0
    (folder / f"{name}.log").write_text(proc.stdout + proc.stderr + f"\nexit {proc.returncode}\n")
    return {"exit": proc.returncode, "wall_s": round(wall, 1)}


def limits_of(data: dict) -> Drive:
    """The drive limits the envelope check needs, from a system file's ``[drive]``."""
    return Drive.from_dict(data["drive"])


def rows_of(name: str, data: dict, folder: Path) -> list[dict]:
    """One row per scenario: powers, period, peaks recomputed from the trajectories."""
    s = pd.read_parquet(folder / name / "summary.parquet")
    traj = pd.read_parquet(folder / name / "trajectories.parquet")
    limits = limits_of(data)
    w, d = data["winch"], data["drive"]
    radius, gear = w["drum_radius_m"], w["gear_ratio"]
    inertia = d.get("rotor_inertia_kg_m2", 0.0) + w.get("drum_inertia_kg_m2", 0.0) / gear**2
    rows = []
    for _, r in s.sort_values(["kind", "wind_speed_m_s"]).iterrows():
        t = traj[traj["scenario"] == r["scenario"]]
        row = {"case": name, "scenario": r["scenario"], "status": r["status"],
               "p_elec_w": r["avg_p_elec_w"], "p_mech_w": r["avg_p_mech_w"],
               "period_s": r["period_s"], "active_bounds": r.get("active_bounds", "")}
        if len(t):
            torque = t["torque_nm"].abs().to_numpy()
            row.update(
                peak_reel_acceleration_m_s2=float(t["ddl_m_s2"].abs().max()),
                peak_shaft_torque_nm=float(torque.max()),
                # recomputed from the tension and the reel acceleration, not the OCP's
                # column: tether torque at the motor plus J_motor * motor acceleration
                peak_shaft_torque_recomputed_nm=float(np.max(np.abs(
                    t["l_m"] * t["nu_n_per_m"] * radius / gear
                    - inertia * gear * t["ddl_m_s2"] / radius))),
                peak_tether_torque_nm=float(t["tether_torque_nm"].abs().max()),
                envelope_ratio=float(np.max(torque / envelope_torque_nm(
                    limits, t["speed_rpm"].to_numpy()))) if r["drive_limits"] else None)
        rows.append(row)
    return rows


def compare(folder: Path, reference: Path) -> float:
    """Largest |dP_elec|, |dP_mech| [W] of ``paper-0`` against a reference sweep."""
    a = pd.read_parquet(folder / "paper-0" / "summary.parquet").set_index("scenario")
    b = pd.read_parquet(reference / "summary.parquet").set_index("scenario")
    common = a.index.intersection(b.index)
    return float(max((a.loc[common, c] - b.loc[common, c]).abs().max()
                     for c in ("avg_p_elec_w", "avg_p_mech_w")))


def claims_table(folder: Path, names: list[str]) -> str:
    """The paper's claims side by side for the paper cases that wrote ``claims.csv``:
    per claim, each case's value and verdict (markdown)."""
    tables = {n: read_claims(folder / n).set_index("claim_id") for n in names
              if n.startswith("paper") and (folder / n / CLAIMS_FILE).is_file()}
    if not tables:
        return ""
    lines = ["| claim | " + " | ".join(tables) + " |", "|---|" + "---|" * len(tables)]
    for claim in next(iter(tables.values())).index:
        cells = [f"{t.loc[claim, 'ours']} ({t.loc[claim, 'verdict']})" if claim in t.index
                 else "-" for t in tables.values()]
        lines.append(f"| {claim} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _markdown(rows: list[dict]) -> str:
    cols = ["case", "scenario", "status", "p_elec_w", "p_mech_w", "period_s",
            "peak_reel_acceleration_m_s2", "peak_shaft_torque_nm",
            "peak_shaft_torque_recomputed_nm", "peak_tether_torque_nm",
            "envelope_ratio", "active_bounds"]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = [f"{r.get(c):.4g}" if isinstance(r.get(c), float) else str(r.get(c, ""))
                 for c in cols]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="paper-0,paper,paper-2x,ap2,megawes,ap2-awebox")
    ap.add_argument("--ablate", action="store_true",
                    help="also the ap2-awebox ablations, one change at a time")
    ap.add_argument("--reference", type=Path, help="optimize_out/ of the massless OCP")
    ap.add_argument("--from", dest="source", type=Path,
                    help="read the runs from this folder instead of running them")
    ap.add_argument("--claims", action="store_true",
                    help="compare the paper cases with the paper's claims (claims.csv)")
    args = ap.parse_args()
    all_cases = cases(args.ablate)
    names = [n for n in args.cases.split(",") if n] + (
        [n for n in all_cases if n.startswith("ap2-awebox-")] if args.ablate else [])
    folder = args.source or Path(tempfile.mkdtemp(prefix="drivetrain_effect_"))
    report: dict = {"folder": str(folder), "cases": {}, "rows": []}
    for name in names:
        data, grid, kinds = all_cases[name]
        if args.source is None:
            print(f"running {name} ...", flush=True)
            report["cases"][name] = run_case(name, data, grid, kinds, folder, args.claims)
        report["rows"] += rows_of(name, data, folder)
    if args.reference is not None and "paper-0" in names:
        report["paper_0_max_dp_w"] = compare(folder, args.reference)
    awebox = [r for r in report["rows"] if r["case"].startswith("ap2-awebox")]
    for r in awebox:
        r["rel_p_mech_vs_awebox"] = r["p_mech_w"] / AWEBOX_AP2["p_mech_w"] - 1
        r["rel_period_vs_awebox"] = r["period_s"] / AWEBOX_AP2["period_s"] - 1
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "drivetrain_effect.json").write_text(json.dumps(report, indent=1, default=str))
    print(_markdown(report["rows"]))
    print(claims_table(folder, names))
    print(json.dumps(report["cases"], indent=1))
    if "paper_0_max_dp_w" in report:
        print(f"paper-0 against {args.reference}: max |dP| = {report['paper_0_max_dp_w']:.4f} W")
    for r in awebox:
        print(f"{r['case']}: P_mech {r['p_mech_w']:.0f} W ({r['rel_p_mech_vs_awebox']:+.1%} vs "
              f"awebox 4.4 kW), period {r['period_s']:.1f} s "
              f"({r['rel_period_vs_awebox']:+.1%} vs 39.6 s)")


if __name__ == "__main__":
    main()
