"""Hostile cases against what drivebench keeps between runs (issue 51's classes, cases
nobody listed): a poisoned record of another kind, a store file from another problem, a
damaged or forged file of an output folder read by a later stage, contradictory bounds
of another pair of parts. Each case runs the real ``bench`` commands in a fresh folder
and prints one line: its verdict and what happened::

    .venv/bin/python benchmarks/hostile_kept_files.py [--work DIR] [--only NAME,...]

Verdicts: ``clean`` (a correct result, or a refusal that names the file or the keys, exit
non-zero, no traceback, nothing kept lost), ``unclear`` (a traceback, or a refusal that
does not say what is wrong), ``wrong`` (exit 0 with a result that is not the
undamaged run's), ``damage`` (a good output replaced or removed).
The sweeps are coarse (10 intervals, one or two wind speeds); the base runs are a sweep,
its AEP (also refined, at most 4 points a kind) and a sizing, and one sweep of another
system for the cases that need one. ``scheduler_killed_mid_size`` starts a Dask scheduler
and worker on port 8798 (drivebench[dask]).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from optimize.problem.deadline import SCENARIO_CALLS

ROOT = Path(__file__).resolve().parents[1]
BENCH = [sys.executable, "-m", "drivebench.cli"]
SITE = ["--weibull-k", "2", "--mean-speed", "6", "--height-m", "100"]
COARSE = ["--intervals", "10", "--no-progress"]


def bench(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """One ``bench`` command in ``cwd``: its exit code, stdout and stderr."""
    return subprocess.run([*BENCH, *args], cwd=cwd, capture_output=True, text=True,
                          check=False)


def said(run: subprocess.CompletedProcess) -> str:
    """The last line the command wrote on stderr (else stdout), for the case's line."""
    lines = (run.stderr.strip() or run.stdout.strip()).splitlines()
    return lines[-1][:220] if lines else ""


def refused(run: subprocess.CompletedProcess, *names: str) -> tuple[str, str]:
    """Clean when the command stopped non-zero, without a traceback, naming ``names``."""
    text = run.stdout + run.stderr
    if "Traceback" in text:
        return "unclear", f"traceback: {said(run)}"
    if run.returncode == 0:
        return "wrong", f"exit 0: {said(run)}"
    missing = [n for n in names if n not in text]
    if missing:
        return "unclear", f"exit {run.returncode}, not naming {missing}: {said(run)}"
    return "clean", f"exit {run.returncode}: {said(run)}"


class Work:
    """The runs every case starts from, made once: a coarse sweep, its AEP, a sizing."""

    def __init__(self, root: Path) -> None:
        self.root = root
        base = root / "base"
        base.mkdir(parents=True, exist_ok=True)
        self.base = base
        runs = [
            ("optimize", "--wind-grid", "7,8.5", "--scenarios", "elec-lim,mech-lim",
             "--no-claims", "--out", "optimize_out", *COARSE),
            ("aep", "--optimize", "optimize_out", "--out", "aep_out", *SITE),
            ("aep", "--optimize", "optimize_out", "--out", "aep_refine", "--refine",
             "--refine-max-points", "4", "--no-progress", *SITE),
            ("size", "--scales", "1,1.5", "--wind-grid", "7,8.5", "--extend", "0",
             "--out", "size_out", *COARSE, *SITE),
        ]
        for args in runs:
            if not (base / args[args.index("--out") + 1]).is_dir():
                run = bench(*args, cwd=base)
                if run.returncode not in (0, 3):
                    raise SystemExit(f"bench {' '.join(args)} failed: {said(run)}")

    def other_system_sweep(self) -> Path:
        """A folder with a sweep of another system (highwind.toml, its period bound moved),
        made once: its own start.npz and summary.parquet."""
        other = self.root / "other_system"
        if not (other / "o_other" / "start.npz").is_file():
            other.mkdir(exist_ok=True)
            system = _system_with(other, "bounds", "period_max_s = 19.0")
            run = bench("optimize", "--system", str(system), "--wind-grid", "7,8.5",
                        "--scenarios", "elec-lim,mech-lim", "--no-claims", "--out", "o_other",
                        *COARSE, cwd=other)
            if run.returncode not in (0, 3):
                raise SystemExit(f"the other system's sweep failed: {said(run)}")
        return other / "o_other"

    def copy(self, name: str) -> Path:
        """A fresh copy of the base runs for the case ``name``."""
        folder = self.root / name
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(self.base, folder)
        return folder


def _sizing_aep(folder: Path) -> dict:
    data = json.loads((folder / "size_out" / "sizing.json").read_text())
    return {c["candidate"]: c.get("aep_elec_mwh") for c in data["candidates"]}


def _solve_files(folder: Path) -> list[Path]:
    return sorted((folder / "size_out" / "solves").glob("*.json"))


def case_record_of_another_candidate(work: Work) -> tuple[str, str]:
    """A stored solve of candidate x1.5, intact, copied over x1's file of the same speed
    (a record of another kind: its own hashes hold, its key is not the file's)."""
    d = work.copy("record_of_another_candidate")
    before = _sizing_aep(d)
    recs = {json.loads(p.read_text()).get("candidate"): p for p in _solve_files(d)}
    if not {"x1", "x1.5"} <= set(recs):
        return "unclear", f"no x1 and x1.5 records to swap: {sorted(map(str, recs))}"
    src, dst = recs["x1.5"], recs["x1"]
    shutil.copy(src, dst)
    shutil.copy(src.with_suffix(".npz"), dst.with_suffix(".npz"))
    run = bench("size", "--scales", "1,1.5", "--wind-grid", "7,8.5", "--extend", "0",
                "--out", "size_out", *COARSE, *SITE, cwd=d)
    after = _sizing_aep(d) if run.returncode == 0 else {}
    if "Traceback" in run.stdout + run.stderr:
        return "unclear", f"traceback: {said(run)}"
    if run.returncode != 0:
        return "unclear", f"exit {run.returncode}: {said(run)}"
    if any(abs((after.get(k) or 0) - (v or 0)) > 1e-6 * max(1.0, abs(v or 0))
           for k, v in before.items()):
        return "wrong", f"AEP {after} against {before}"
    named = dst.name in run.stdout + run.stderr
    return ("clean" if named else "unclear",
            f"AEP unchanged {after}; the file {'named' if named else 'not named'}")


def case_npz_swapped(work: Work) -> tuple[str, str]:
    """Two stored solves' .npz swapped (each intact, each another solve's)."""
    d = work.copy("npz_swapped")
    before = _sizing_aep(d)
    files = [p.with_suffix(".npz") for p in _solve_files(d)]
    if len(files) < 2:
        return "unclear", "fewer than two stored solves"
    a, b = files[0], files[1]
    tmp = a.with_suffix(".tmp")
    a.rename(tmp)
    b.rename(a)
    tmp.rename(b)
    run = bench("size", "--scales", "1,1.5", "--wind-grid", "7,8.5", "--extend", "0",
                "--out", "size_out", *COARSE, *SITE, cwd=d)
    if "Traceback" in run.stdout + run.stderr or run.returncode != 0:
        return "unclear", f"exit {run.returncode}: {said(run)}"
    after = _sizing_aep(d)
    if after != before and any(abs((after[k] or 0) - (before[k] or 0)) > 1e-6
                               for k in before):
        return "wrong", f"AEP {after} against {before}"
    return "clean", f"re-solved, AEP unchanged {after}"


def case_summary_truncated_for_aep(work: Work) -> tuple[str, str]:
    """optimize_out/summary.parquet cut to half, then bench aep of it."""
    d = work.copy("summary_truncated")
    f = d / "optimize_out" / "summary.parquet"
    f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    return _aep_refuses_summary(d)


def _aep_refuses_summary(d: Path) -> tuple[str, str]:
    """bench aep of ``d``'s optimize_out: refused naming summary.parquet, aep_out kept."""
    aep_before = (d / "aep_out" / "aep.json").read_bytes()
    run = bench("aep", "--optimize", "optimize_out", "--out", "aep_out", *SITE, cwd=d)
    verdict = refused(run, "summary.parquet")
    if (d / "aep_out" / "aep.json").read_bytes() != aep_before:
        return "damage", f"aep_out replaced: {said(run)}"
    return verdict


def case_run_json_removed_and_summary_forged(work: Work) -> tuple[str, str]:
    """run.json removed from optimize_out and summary.parquet rewritten with every
    scenario's power doubled (a folder that looks as if written before run ids)."""
    d = work.copy("run_json_removed")
    out = d / "optimize_out"
    (out / "run.json").unlink()
    s = pd.read_parquet(out / "summary.parquet")
    s["avg_p_elec_w"] = 2 * s["avg_p_elec_w"]
    s.to_parquet(out / "summary.parquet")
    run = bench("aep", "--optimize", "optimize_out", "--out", "aep_out", *SITE, cwd=d)
    return refused(run, "run.json")


def case_trajectories_from_another_run(work: Work) -> tuple[str, str]:
    """trajectories.parquet of another sweep (another wind grid) put in optimize_out,
    then bench cycle export of a scenario both have."""
    d = work.copy("trajectories_of_another_run")
    other = bench("optimize", "--wind-grid", "7", "--scenarios", "elec-lim", "--no-claims",
                  "--out", "other_out", *COARSE, cwd=d)
    if other.returncode != 0:
        return "unclear", f"the other sweep failed: {said(other)}"
    shutil.copy(d / "other_out" / "trajectories.parquet",
                d / "optimize_out" / "trajectories.parquet")
    run = bench("cycle", "export", "--optimize", "optimize_out", "--scenario", "elec-lim-7.0",
                "--out", "profile.csv", cwd=d)
    return refused(run, "trajectories.parquet")


def case_fit_model_edited(work: Work) -> tuple[str, str]:
    """A power model in a fit_out/ folder whose run.json records it, one coefficient
    edited, then bench optimize --drive-model of it."""
    from kernel.output_folder import output_folder

    d = work.copy("fit_model_edited")
    model = json.loads((ROOT / "optimize/data/paper_drive_model.json").read_text())
    with output_folder(d / "fit_out", "fit") as stage:  # as bench fit writes its folder
        (stage / "power_model.json").write_text(json.dumps(model))
    model["coefficients"] = {k: [2 * c for c in v] for k, v in model["coefficients"].items()}
    (d / "fit_out" / "power_model.json").write_text(json.dumps(model))
    run = bench("optimize", "--drive-model", "fit_out/power_model.json", "--wind-grid", "7",
                "--scenarios", "elec-lim", "--no-claims", "--out", "o2", *COARSE, cwd=d)
    return refused(run, "power_model.json")


def _system_with(d: Path, section: str, line: str) -> Path:
    """highwind.toml with the key of ``line`` set so in ``[section]`` (its line replaced,
    or added at the section's top)."""
    import re

    text = (ROOT / "optimize/data/systems/highwind.toml").read_text()
    key = line.split("=")[0].strip()
    head = text.index(f"[{section}]\n")
    end = text.find("\n[", head + 1)
    body = text[head:end if end > 0 else len(text)]
    new = (re.sub(rf"^{key}\s*=.*$", line, body, count=1, flags=re.M)
           if re.search(rf"^{key}\s*=", body, flags=re.M)
           else body.replace(f"[{section}]\n", f"[{section}]\n{line}\n", 1))
    path = d / "my_kite.toml"
    path.write_text(text.replace(body, new, 1))
    return path


def _contradiction(name: str, section: str, line: str, *keys: str) -> Callable:
    def case(work: Work) -> tuple[str, str]:
        d = work.copy(name)
        system = _system_with(d, section, line)
        t0 = time.perf_counter()
        run = bench("optimize", "--system", str(system), "--wind-grid", "7", "--scenarios",
                    "elec-lim", "--no-claims", "--out", "o3", *COARSE, cwd=d)
        verdict, text = refused(run, *keys)
        return verdict, f"{text} ({time.perf_counter() - t0:.0f} s)"
    case.__doc__ = f"[{section}] {line}: bounds of two parts that cannot hold together"
    return case


def case_start_of_another_mesh(work: Work) -> tuple[str, str]:
    """bench optimize --start of a sweep of the same system on another mesh (10
    intervals, this one 12): carried over or refused, never a wrong start believed."""
    d = work.copy("start_of_another_mesh")
    run = bench("optimize", "--start", "optimize_out", "--wind-grid", "7", "--scenarios",
                "elec-lim", "--no-claims", "--out", "o4", "--intervals", "12",
                "--no-progress", cwd=d)
    if "Traceback" in run.stdout + run.stderr:
        return "unclear", f"traceback: {said(run)}"
    if run.returncode != 0:
        return refused(run, "start")
    plain = bench("optimize", "--wind-grid", "7", "--scenarios", "elec-lim", "--no-claims",
                  "--out", "o5", "--intervals", "12", "--no-progress", cwd=d)
    got, want = (pd.read_parquet(d / o / "summary.parquet")["avg_p_elec_w"].iloc[0]
                 for o in ("o4", "o5"))
    if plain.returncode != 0 or abs(got - want) > 0.5:
        return "wrong", f"{got:.2f} W from it, {want:.2f} W without (exit {plain.returncode})"
    return "clean", f"solved from it: {got:.2f} W, as without it ({want:.2f} W)"


def case_aep_json_edited_for_report(work: Work) -> tuple[str, str]:
    """aep_out/aep.json edited (an AEP tripled), then bench report."""
    d = work.copy("aep_json_edited")
    f = d / "aep_out" / "aep.json"
    doc = json.loads(f.read_text())

    def triple(node):  # the first AEP figure found, tripled
        if isinstance(node, dict):
            for k, v in node.items():
                if k.startswith("aep_elec") and isinstance(v, float):
                    node[k] = 3 * v
                    return True
                if triple(v):
                    return True
        if isinstance(node, list):
            return any(triple(v) for v in node)
        return False

    if not triple(doc):
        return "unclear", "no AEP figure in aep.json to edit"
    f.write_text(json.dumps(doc))
    run = bench("report", "--optimize", "optimize_out", "--aep", "aep_out",
                "--size", "size_out", "--out", "report.html", cwd=d)
    return refused(run, "aep.json")


def _refine_solve_files(folder: Path) -> list[Path]:
    return sorted((folder / "aep_refine" / "solves").glob("*.json"))


def _refine_again(d: Path) -> subprocess.CompletedProcess:
    return bench("aep", "--optimize", "optimize_out", "--out", "aep_refine", "--refine",
                 "--refine-max-points", "4", "--no-progress", *SITE, cwd=d)


def _refine_store_case(name: str, damage: Callable[[Path], None]) -> Callable:
    def case(work: Work) -> tuple[str, str]:
        d = work.copy(name)
        files = _refine_solve_files(d)
        if not files:
            return "unclear", "bench aep --refine stored no solve to damage"
        before = (d / "aep_refine" / "aep.json").read_text()
        damage(files[0])
        run = _refine_again(d)
        text = run.stdout + run.stderr
        if "Traceback" in text or run.returncode != 0:
            return "unclear", f"exit {run.returncode}: {said(run)}"
        after = (d / "aep_refine" / "aep.json").read_text()
        a, b = _aep_numbers(after), _aep_numbers(before)
        if len(a) != len(b) or any(abs(x - y) > 1e-4 * max(1.0, abs(y))
                                   for x, y in zip(a, b, strict=True)):
            return "wrong", f"AEP {a} against {b}"
        named = files[0].stem in text
        return ("clean" if named else "unclear",
                f"AEP unchanged; the record {'named' if named else 'not named'}: "
                f"{[ln for ln in text.splitlines() if files[0].stem in ln][:1]}")
    case.__doc__ = f"bench aep --refine's stored solve: {name}"
    return case


def _aep_numbers(text: str) -> list:
    """Every AEP figure of an aep.json, rounded to 1e-6 MWh/yr."""
    found = []

    def walk(node):
        if isinstance(node, dict):
            for k, v in node.items():
                if k.startswith("aep_elec") and isinstance(v, float):
                    found.append(round(v, 6))
                else:
                    walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)
    walk(json.loads(text))
    return found


def _edit_json(path: Path, edit: Callable[[dict], None]) -> None:
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))


def case_start_of_another_system(work: Work) -> tuple[str, str]:
    """bench optimize --start of another system's start.npz (the shipped system's sweep
    started from a sweep of highwind.toml with its period bound moved)."""
    other = work.other_system_sweep()
    d = work.copy("start_of_another_system")
    run = bench("optimize", "--start", str(other / "start.npz"), "--wind-grid", "7",
                "--scenarios", "elec-lim", "--no-claims", "--out", "o6", *COARSE, cwd=d)
    return refused(run, "start.npz", "another system")


def case_summary_of_another_system(work: Work) -> tuple[str, str]:
    """summary.parquet of another system's sweep copied into optimize_out, then bench aep."""
    other = work.other_system_sweep()
    d = work.copy("summary_of_another_system")
    shutil.copy(other / "summary.parquet", d / "optimize_out" / "summary.parquet")
    return _aep_refuses_summary(d)


def case_sizing_json_edited_for_report(work: Work) -> tuple[str, str]:
    """size_out/sizing.json with a candidate's AEP tripled, then bench report."""
    d = work.copy("sizing_json_edited")
    f = d / "size_out" / "sizing.json"
    _edit_json(f, lambda doc: doc["candidates"][0].update(
        aep_elec_mwh=3 * (doc["candidates"][0].get("aep_elec_mwh") or 1.0)))
    run = bench("report", "--optimize", "optimize_out", "--aep", "aep_out",
                "--size", "size_out", "--out", "report.html", cwd=d)
    return refused(run, "sizing.json")


def case_scheduler_killed_mid_size(work: Work) -> tuple[str, str]:
    """The Dask scheduler killed (SIGKILL) 10 s into a bench size on it (35 solves on 20
    intervals, a minute or more): a clear end in a stated time, the earlier sizing and
    the stored solves kept."""
    import os
    import signal

    d = work.copy("scheduler_killed_mid_size")
    dask = str(Path(sys.executable).parent / "dask")
    port = "8798"
    procs = []
    try:
        procs.append(subprocess.Popen([dask, "scheduler", "--port", port, "--no-dashboard"],
                                      cwd=d, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        time.sleep(5)
        # the worker in the case's folder: it stores the solves at the relative --out
        procs.append(subprocess.Popen([dask, "worker", f"tcp://127.0.0.1:{port}",
                                       "--nthreads", "1", "--no-dashboard"], cwd=d,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        time.sleep(8)
        before = (d / "size_out" / "sizing.json").read_bytes()
        n_before = len(_solve_files(d))
        t0 = time.perf_counter()
        size = subprocess.Popen([*BENCH, "size", "--scales", "0.75,1,1.25,1.5,2",
                                 "--wind-grid", "6:12:1", "--extend", "0", "--out",
                                 "size_out", "--scheduler", f"tcp://127.0.0.1:{port}",
                                 "--intervals", "20", "--no-progress", *SITE], cwd=d,
                                stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        time.sleep(10)
        killed_at = time.perf_counter() - t0
        os.kill(procs[0].pid, signal.SIGKILL)
        out, err = size.communicate(timeout=600)
        run = subprocess.CompletedProcess(size.args, size.returncode, out, err)
        if run.returncode == 0:
            return "unclear", f"the sizing finished before the scheduler was killed: {said(run)}"
        verdict, text = refused(run, "scheduler")
        if (d / "size_out" / "sizing.json").read_bytes() != before:
            return "damage", f"the earlier sizing replaced: {said(run)}"
        return verdict, (f"{text}; killed {killed_at:.0f} s in, ended "
                         f"{time.perf_counter() - t0 - killed_at:.0f} s later; the earlier "
                         f"sizing kept, {len(_solve_files(d))} stored solves ({n_before} "
                         "before)")
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()


def _thermal_model_file(path: Path, r_th_k_per_w: float) -> None:
    """The shipped paper model with a one-node thermal block of ``r_th_k_per_w`` [K/W]
    (tau 900 s), written to ``path``."""
    model = json.loads((ROOT / "optimize/data/paper_drive_model.json").read_text())
    model["schema_version"] = 3
    model["thermal"] = {"nodes": 1, "r_th_k_per_w": r_th_k_per_w, "tau_th_s": 900.0,
                        "c_th_j_per_k": 900.0 / r_th_k_per_w,
                        "copper_temp_coeff_per_k": 0.00393, "theta_ref_c": 20.0,
                        "ambient_c": 25.0}
    path.write_text(json.dumps(model))


def case_thermal_block_absurd(work: Work) -> tuple[str, str]:
    """A power model whose thermal block has r_th 1e6 K/W, flown with a 120 degC winding
    limit: refused before any solve, naming the block and the limit."""
    d = work.copy("thermal_block_absurd")
    _thermal_model_file(d / "hot.json", 1e6)
    system = _system_with(d, "drive", "max_winding_temperature_c = 120.0")
    t0 = time.perf_counter()
    run = bench("optimize", "--system", str(system), "--drive-model", "hot.json",
                "--wind-grid", "7", "--scenarios", "elec-lim", "--no-claims", "--out", "o7",
                *COARSE, cwd=d)
    verdict, text = refused(run, "thermal", "max_winding_temperature_c")
    return verdict, f"{text} ({time.perf_counter() - t0:.0f} s)"


def _fatrop_verdict(run: subprocess.CompletedProcess, out: Path, reference: Path | None,
                    seconds: float, bound_s: float) -> tuple[str, str]:
    """A fatrop sweep: clean when it ends without a traceback within ``bound_s`` (its
    scenarios' budgets, :data:`optimize.problem.deadline.SCENARIO_CALLS` + 1 call limits
    each, and a minute for the NLP builds) and either converges (to IPOPT's optima of
    ``reference`` within 1 % where given) or names the failures and ``--solver ipopt``."""
    text = run.stdout + run.stderr
    took = f"({seconds:.0f} s)"
    if "Traceback" in text:
        return "unclear", f"traceback: {said(run)} {took}"
    if seconds > bound_s + 60:
        return "unclear", f"ran past its bound of {bound_s:.0f} s: {said(run)} {took}"
    summary = pd.read_parquet(out / "summary.parquet").set_index("scenario")
    failed = summary.index[~summary["success"]].tolist()
    if failed and "--solver ipopt" not in run.stdout:
        return "unclear", f"exit {run.returncode}, {failed} failed, no option named {took}"
    if reference is not None:
        ref = pd.read_parquet(reference / "summary.parquet").set_index("scenario")
        for name in summary.index[summary["success"]]:
            got, want = (summary.loc[name, "avg_p_elec_w"], ref.loc[name, "avg_p_elec_w"])
            if abs(got - want) > 0.01 * abs(want):
                return "wrong", f"{name} P_elec {got:.2f} W, IPOPT {want:.2f} W {took}"
    return "clean", (f"exit {run.returncode}, {len(summary) - len(failed)}/{len(summary)} "
                     f"converged, failed {failed or 'none'}: {said(run)} {took}")


def case_fatrop_condensed_sweep(work: Work) -> tuple[str, str]:
    """The base sweep's grid (coarse) by fatrop on the condensed NLP: converged to IPOPT's
    optima, or its failures named with --solver ipopt, within the stated call limits."""
    d = work.copy("fatrop_condensed_sweep")
    t0 = time.perf_counter()
    run = bench("optimize", "--wind-grid", "7,8.5", "--scenarios", "elec-lim,mech-lim",
                "--no-claims", "--out", "o_fatrop", "--solver", "fatrop", "--transcription",
                "condensed", "--call-time-limit", "30", *COARSE, cwd=d)
    return _fatrop_verdict(run, d / "o_fatrop", d / "optimize_out", time.perf_counter() - t0,
                           4 * (SCENARIO_CALLS + 1) * 30)


def case_fatrop_condensed_winding_limit(work: Work) -> tuple[str, str]:
    """A 90 degC winding limit (a thermal block of r_th 0.05 K/W) by fatrop on the
    condensed NLP at 8 m/s: converged, or failed within the stated call limits naming
    --solver ipopt (was: exception: FloatingPointError ... singular block)."""
    d = work.copy("fatrop_condensed_winding_limit")
    _thermal_model_file(d / "warm.json", 0.05)
    system = _system_with(d, "drive", "max_winding_temperature_c = 90.0")
    t0 = time.perf_counter()
    run = bench("optimize", "--system", str(system), "--drive-model", "warm.json",
                "--wind-grid", "8", "--scenarios", "elec-lim", "--no-claims", "--out", "o8",
                "--solver", "fatrop", "--transcription", "condensed", "--call-time-limit", "20",
                *COARSE, cwd=d)
    return _fatrop_verdict(run, d / "o8", None, time.perf_counter() - t0,
                           (SCENARIO_CALLS + 1) * 20)



def _bad_input(name: str, args: tuple[str, ...], *keys: str,
               prepare: Callable[[Path], None] | None = None) -> Callable:
    """``bench *args`` in a copy of the base runs (after ``prepare`` of the folder): refused
    naming ``keys``, no traceback, within seconds."""
    def case(work: Work) -> tuple[str, str]:
        d = work.copy(name)
        if prepare is not None:
            prepare(d)
        t0 = time.perf_counter()
        verdict, text = refused(bench(*args, cwd=d), *keys)
        return verdict, f"{text} ({time.perf_counter() - t0:.0f} s)"
    case.__doc__ = f"bench {' '.join(args)}: refused naming {', '.join(keys)}"
    return case


def _cut(path: str, size: int) -> Callable[[Path], None]:
    def prepare(d: Path) -> None:
        (d / path).write_bytes((d / path).read_bytes()[:size])
    return prepare


def _nan_coefficient(d: Path) -> None:
    model = json.loads((ROOT / "optimize/data/paper_drive_model.json").read_text())
    model["coefficients"]["rpm"][2] = float("nan")
    (d / "nan.json").write_text(json.dumps(model))


def _toml_syntax_error(d: Path) -> None:
    text = (ROOT / "optimize/data/systems/highwind.toml").read_text()
    (d / "broken.toml").write_text(text.replace("mass_kg = 7.5", "mass_kg = = 7.5", 1))


_OPT = ("optimize", "--wind-grid", "7", "--scenarios", "elec-lim", "--no-claims", "--out",
        "o_bad", *COARSE)
_AEP = ("aep", "--optimize", "optimize_out", "--out", "aep_bad", *SITE)


CASES = {
    "record_of_another_candidate": case_record_of_another_candidate,
    "npz_swapped": case_npz_swapped,
    "summary_truncated": case_summary_truncated_for_aep,
    "run_json_removed": case_run_json_removed_and_summary_forged,
    "trajectories_of_another_run": case_trajectories_from_another_run,
    "fit_model_edited": case_fit_model_edited,
    "start_of_another_mesh": case_start_of_another_mesh,
    "aep_json_edited": case_aep_json_edited_for_report,
    "clearance_above_tether": _contradiction(
        "clearance_above_tether", "bounds", "min_ground_clearance_m = 1000.0",
        "min_ground_clearance_m"),
    "tension_floor_above_tether_force": _contradiction(
        "tension_floor_above_tether_force", "bounds", "min_tension_n = 1.0e6",
        "min_tension_n"),
    # helper-10, issue 51's last session: more of the same classes
    "aep_refine_record_poisoned": _refine_store_case(
        "aep_refine_record_poisoned", lambda p: _edit_json(
            p, lambda d: d.update(avg_p_elec_w=3 * d["avg_p_elec_w"]))),
    "aep_refine_npz_truncated": _refine_store_case(
        "aep_refine_npz_truncated", lambda p: p.with_suffix(".npz").write_bytes(
            p.with_suffix(".npz").read_bytes()[:200])),
    "start_of_another_system": case_start_of_another_system,
    "summary_of_another_system": case_summary_of_another_system,
    "sizing_json_edited": case_sizing_json_edited_for_report,
    "scheduler_killed_mid_size": case_scheduler_killed_mid_size,
    "thermal_block_absurd": case_thermal_block_absurd,
    "base_speed_leaves_no_envelope": _contradiction(
        "base_speed_leaves_no_envelope", "drive", "base_speed_rpm = 0.001", "base_speed_rpm"),
    # helper-13: fatrop on the condensed NLP, the last unmet case
    "fatrop_condensed_sweep": case_fatrop_condensed_sweep,
    "fatrop_condensed_winding_limit": case_fatrop_condensed_winding_limit,
    # helper-13: more of the classes (other contradictions, other damaged files, bad options)
    "alpha_bounds_crossed": _contradiction(
        "alpha_bounds_crossed", "aero", "alpha_min_deg = 9.0", "alpha_max_deg", "[9, 8.5]"),
    "period_bounds_crossed": _contradiction(
        "period_bounds_crossed", "bounds", "period_min_s = 30.0", "period_min_s"),
    "tether_bounds_crossed": _contradiction(
        "tether_bounds_crossed", "bounds", "tether_length_min_m = 600.0",
        "tether_length_min_m"),
    "drum_radius_zero": _contradiction(
        "drum_radius_zero", "winch", "drum_radius_m = 0.0", "drum_radius_m"),
    "max_speed_zero": _contradiction(
        "max_speed_zero", "drive", "max_speed_rpm = 0.0", "max_speed_rpm"),
    "start_npz_truncated": _bad_input(
        "start_npz_truncated", (*_OPT, "--start", "optimize_out/start.npz"), "start.npz",
        prepare=_cut("optimize_out/start.npz", 300)),
    "drive_model_nan": _bad_input(
        "drive_model_nan", (*_OPT, "--drive-model", "nan.json"), "nan.json",
        prepare=_nan_coefficient),
    "system_toml_syntax": _bad_input(
        "system_toml_syntax", (*_OPT, "--system", "broken.toml"), "broken.toml",
        prepare=_toml_syntax_error),
    "run_json_truncated_for_aep": _bad_input(
        "run_json_truncated_for_aep", _AEP, "run.json",
        prepare=_cut("optimize_out/run.json", 40)),
    "intervals_zero": _bad_input("intervals_zero", (*_OPT, "--intervals", "0"), "--intervals"),
    "call_time_limit_nan": _bad_input(
        "call_time_limit_nan", (*_OPT, "--call-time-limit", "nan"), "--call-time-limit"),
    "period_scan_too_many": _bad_input(
        "period_scan_too_many", (*_OPT, "--period-scan", "100"), "--period-scan"),
    "linear_solver_with_fatrop": _bad_input(
        "linear_solver_with_fatrop", (*_OPT, "--solver", "fatrop", "--linear-solver", "ma27"),
        "--linear-solver"),
    "aep_mean_speed_negative": _bad_input(
        "aep_mean_speed_negative", ("aep", "--optimize", "optimize_out", "--out", "aep_bad",
                                    "--weibull-k", "2", "--mean-speed", "-1",
                                    "--height-m", "100"), "--mean-speed"),
    "size_scales_nan": _bad_input(
        "size_scales_nan", ("size", "--scales", "1,nan", "--wind-grid", "7,8.5", "--out", "s_bad",
                            *COARSE, *SITE), "--scales"),
}


def main() -> None:
    """Run the cases (all, or those of ``--only``) and print one line each."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=None, help="folder for the runs (kept)")
    ap.add_argument("--only", default="", help="comma list of case names")
    args = ap.parse_args()
    root = args.work or Path(tempfile.mkdtemp(prefix="hostile_kept_"))
    work = Work(root)
    names = [n for n in args.only.split(",") if n] or list(CASES)
    for name in names:
        t0 = time.perf_counter()
        verdict, text = CASES[name](work)
        print(f"{verdict:8s} {name}: {text} [{time.perf_counter() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
