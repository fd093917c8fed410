"""Kites that are not the paper's: how their sweeps start, what they cost, where they land.

Usage::

    .venv/bin/python benchmarks/foreign_kites.py [--kites paper,ap2,megawes,ap2x0.7,glider30]
        [--wind-grid 4:14:2] [--scenarios elec-lim,elec-free,mech-lim,mech-free]
        [--bench PATH] [--baseline OLD.json] [--out benchmarks/out/foreign_kites]

Each kite is swept by ``bench optimize --system FILE --no-claims`` in a child process
(``--bench``: another checkout's ``bench``, to measure an older version on the same
files). The kites:

* ``paper``: the shipped ``highwind.toml`` (the paper's kite: it starts from the shipped
  solution of itself), the yardstick;
* ``ap2``, ``megawes``: the shipped AP2- and MegAWES-size files;
* ``ap2x0.7``: made here, ``ap2.toml`` scaled geometrically by 0.7 in length (area
  x0.49, mass x0.343, inertias x0.168, the tether force limit x0.49 and the drive's torque
  with it, the nominal power x0.49);
* ``glider30``: made here, ``highwind_drivetrain.toml`` (the paper's kite with its drum's
  and rotor's inertia) with a 30 kg kite and a 5 m/s^2 reel-acceleration limit, as a new
  user would write it.

Per kite it prints: scenarios converged, IPOPT iterations per reported solve (median,
90th percentile, max), the intermediate points and their iterations, the iterations in
all (the manifest's; a version without that record: the reported ones), the wall and the
CPU time of the child (``os.wait4``), the 1-minute load; and with ``--baseline`` (this
script's JSON of another version) each optimum against it: the same within 0.1 % of the
objective's power, better, or poorer. Writes ``foreign_kites.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
SYSTEMS = ROOT / "optimize" / "data" / "systems"
#: the objective power's column of each kind
OBJECTIVE = {"elec": "avg_p_elec_w", "mech": "avg_p_mech_w"}
#: two optima within this fraction of the objective's power are the same
SAME_RTOL = 1e-3


def _set(text: str, section: str, key: str, value: float) -> str:
    """``text`` (TOML) with ``key`` of ``[section]`` set to ``value`` (the line replaced,
    or added at the section's head)."""
    lines, inside, done = text.splitlines(), False, False
    for i, line in enumerate(lines):
        if line.strip().startswith("["):
            inside = line.strip() == f"[{section}]"
            if inside and not any(ln.split("=")[0].strip() == key for ln in lines
                                  if "=" in ln):
                lines.insert(i + 1, f"{key} = {value!r}")
                done = True
                break
        elif inside and "=" in line and line.split("=")[0].strip() == key:
            lines[i] = f"{key} = {value!r}"
            done = True
            break
    assert done, (section, key)
    return "\n".join(lines) + "\n"


def scaled_ap2(k: float) -> str:
    """``ap2.toml`` scaled geometrically by ``k`` in length (module docstring)."""
    text = (SYSTEMS / "ap2.toml").read_text()
    data = tomllib.loads(text)
    kite, tether, drive = data["kite"], data["tether"], data["drive"]
    for key, power in (("mass_kg", 3), ("reference_area_m2", 2), ("span_m", 1),
                       ("chord_m", 1), ("inertia_xx_kg_m2", 5), ("inertia_yy_kg_m2", 5),
                       ("inertia_zz_kg_m2", 5), ("inertia_xz_kg_m2", 5)):
        text = _set(text, "kite", key, kite[key] * k**power)
    text = _set(text, "tether", "max_force_n", tether["max_force_n"] * k**2)
    text = _set(text, "drive", "max_torque_nm", drive["max_torque_nm"] * k**2)
    text = _set(text, "drive", "nominal_power_w", drive["nominal_power_w"] * k**2)
    return text.replace('name = "ap2"', f'name = "ap2x{k:g}"', 1)


def glider30() -> str:
    """``highwind_drivetrain.toml`` with a 30 kg kite and a 5 m/s^2 reel acceleration."""
    text = (SYSTEMS / "highwind_drivetrain.toml").read_text()
    text = _set(text, "kite", "mass_kg", 30.0)
    text = _set(text, "winch", "max_reel_acceleration_m_s2", 5.0)
    name = tomllib.loads(text)["system"]["name"]
    return text.replace(f'name = "{name}"', 'name = "glider30"', 1)


def system_file(kite: str, out: Path) -> Path:
    """The system file of ``kite`` (a shipped one, or written into ``out``)."""
    made = {"ap2x0.7": lambda: scaled_ap2(0.7), "glider30": glider30}
    if kite in made:
        path = out / f"{kite}.toml"
        path.write_text(made[kite]())
        return path
    return SYSTEMS / ("highwind.toml" if kite == "paper" else f"{kite}.toml")


def sweep(bench: str, system: Path, wind_grid: str, scenarios: str, folder: Path) -> dict:
    """One ``bench optimize`` in a child process: its exit code, wall and CPU time."""
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen([bench, "optimize", "--system", str(system), "--wind-grid",
                             wind_grid, "--scenarios", scenarios, "--no-claims",
                             "--no-progress", "--out", str(folder)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    log = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    (folder.parent / f"{folder.name}.log").write_text(log)
    return {"exit": proc.returncode, "wall_s": time.perf_counter() - t0,
            "cpu_s": usage.ru_utime + usage.ru_stime, "load_1min": load}


def figures(folder: Path) -> dict:
    """Iterations and optima of a sweep folder."""
    s = pd.read_parquet(folder / "summary.parquet")
    manifest = json.loads((folder / "manifest.json").read_text())
    its = s.loc[s["success"], "iterations"].astype(int).tolist()
    way = manifest.get("iterations", {})
    optima = {r.scenario: (float(getattr(r, OBJECTIVE[r.kind[:4]])) if r.success else math.nan)
              for r in s.itertuples()}
    return {
        "converged": int(s["success"].sum()), "scenarios": len(s),
        "failed": s.loc[~s["success"], "scenario"].tolist(),
        "median_it": statistics.median(its) if its else math.nan,
        "p90_it": float(pd.Series(its).quantile(0.9)) if its else math.nan,
        "max_it": max(its, default=0), "reported_it": int(s["iterations"].sum()),
        "intermediate_points": int(way.get("intermediate_points", 0)),
        "intermediate_it": int(way.get("intermediate_iterations", 0)),
        "all_it": int(way.get("all", s["iterations"].sum())),
        "cold_it": s.loc[s["depth"] == 0, "iterations"].astype(int).tolist(),
        "optima_w": optima,
    }


def compare(now: dict[str, float], before: dict[str, float]) -> dict[str, str]:
    """Each optimum against ``before``'s: ``same``, ``better`` or ``poorer`` (by more than
    :data:`SAME_RTOL` of the power), ``new`` or ``lost`` (converged in one only)."""
    out = {}
    for name, p in now.items():
        b = before.get(name, math.nan)
        if math.isnan(p) or math.isnan(b):
            out[name] = "lost" if math.isnan(p) and not math.isnan(b) else (
                "new" if not math.isnan(p) and math.isnan(b) else "failed in both")
        elif abs(p - b) <= SAME_RTOL * abs(b):
            out[name] = "same"
        else:
            out[name] = "better" if p < b else "poorer"
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kites", default="paper,ap2,megawes,ap2x0.7,glider30")
    ap.add_argument("--wind-grid", default="4:14:2")
    ap.add_argument("--scenarios", default="elec-lim,elec-free,mech-lim,mech-free")
    ap.add_argument("--bench", default=str(Path(sys.executable).parent / "bench"))
    ap.add_argument("--baseline", type=Path)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "foreign_kites")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    before = json.loads(args.baseline.read_text()) if args.baseline else {}
    results = {}
    for kite in args.kites.split(","):
        folder = args.out / kite
        run = sweep(args.bench, system_file(kite, args.out), args.wind_grid, args.scenarios,
                    folder)
        row = {**run, **(figures(folder) if (folder / "summary.parquet").is_file() else {})}
        if kite in before and "optima_w" in row:
            row["against_baseline"] = compare(row["optima_w"], before[kite]["optima_w"])
        results[kite] = row
        print(line(kite, row), flush=True)
    (args.out / "foreign_kites.json").write_text(json.dumps(results, indent=1) + "\n")
    return 0


def line(kite: str, r: dict) -> str:
    """One kite's figures in a line."""
    if "converged" not in r:
        return f"{kite:<9} exit {r['exit']}: no summary"
    text = (f"{kite:<9} {r['converged']}/{r['scenarios']} converged; it per solve median "
            f"{r['median_it']:.0f}, p90 {r['p90_it']:.0f}, max {r['max_it']}; cold "
            f"{r['cold_it']}; intermediate {r['intermediate_points']} points "
            f"{r['intermediate_it']} it; reported {r['reported_it']}, all {r['all_it']} it; "
            f"wall {r['wall_s']:.0f} s, CPU {r['cpu_s']:.0f} s (load {r['load_1min']:.1f})")
    if r["failed"]:
        text += f"; FAILED {','.join(r['failed'])}"
    if "against_baseline" in r:
        verdicts = r["against_baseline"]
        counts = {v: sum(x == v for x in verdicts.values()) for v in sorted(set(verdicts.values()))}
        poorer = [n for n, v in verdicts.items() if v in ("poorer", "lost")]
        text += f"; against the baseline {counts}" + (f" ({', '.join(poorer)})" if poorer else "")
    return text


if __name__ == "__main__":
    sys.exit(main())
