"""`bench report`: contents against known inputs, partial inputs, bad input, escaping, browser.

The inputs are small hand-written files that follow docs/schemas.md (§2 store,
§3 model, §4 fit, §5 optimize), built from known truths so each figure in the
report can be checked: operating points from the paper's quadratic (docs/paper_figures.md
§1) plus Gaussian noise of known standard deviation, a model file with a known
covariance, and analytic pumping cycles whose net energy is known exactly.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import stat
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivebench.cli import main
from fitting.figures import efficiency_grid
from fitting.fit_folder import FitContents, write_fit_files
from fitting.power_model import PowerModel
from kernel.drive import Drive
from kernel.files import write_text_atomic
from kernel.output_folder import output_folder
from kernel.provenance import Provenance
from kernel.sections import bound_values
from optimize.cycles import Cycle, cycle_quadrature
from optimize.paper_model import paper_model
from optimize.sweep_folder import (
    SUMMARY_FILE,
    read_claims,
    read_manifest,
    read_summary,
    read_trajectories,
    write_sweep_folder,
)
from reports.render import build_context, build_report, render
from reports.svg import new_figure, to_svg

NOISE_W = 120.0  # standard deviation of the synthetic measurement noise [W]
XSS = "<script>alert(1)</script>"
SE_RPM = (5.0, 2e-6, 4e-4, 3e-4)  # standard errors written into the model's covariance
FAILED_STATUS = "Maximum_Iterations_Exceeded"
CYCLE_PERIOD_S, CYCLE_MEAN_P_W = 6.0, -827.0 / 6.0  # Fig. 3 truth: nets -827 J in 6 s
KINDS = ("elec-lim", "elec-free", "mech-lim", "mech-free")
WINDS = (4.0, 5.5, 7.0, 8.5, 10.0)


# ----------------------------------------------------------------------- inputs
def _points(rng: np.random.Generator) -> pd.DataFrame:
    """Motor and generator operating points on the paper's quadratic plus noise."""
    motor = [(s, t) for s in np.linspace(50, 1500, 12) for t in np.linspace(5, 78, 12)]
    gen = [(-s, t) for s in np.linspace(100, 3000, 12) for t in np.linspace(5, 78, 12)
           if s * t * 2 * np.pi / 60 <= 10_000.0]
    rows = [("motor_01", "motor", s, t) for s, t in motor] + [
        ("gen_01", "generator", s, t) for s, t in gen]
    frame = pd.DataFrame(rows, columns=["session_id", "mode", "speed_rpm", "torque_nm"])
    frame["point_id"] = frame.groupby("session_id").cumcount().astype("int32")
    frame["p_mech_w"] = frame["speed_rpm"] * 2 * np.pi / 60 * frame["torque_nm"]
    frame["quadrant"] = np.where(frame["p_mech_w"] > 0, "motor", "generator")
    truth = paper_model().p_elec_w(frame["speed_rpm"], frame["torque_nm"])
    frame["p_elec_w"] = truth + rng.normal(0.0, NOISE_W, len(frame))
    frame["source"] = "timeseries"
    for c in ("speed_rpm", "torque_nm", "p_mech_w", "p_elec_w"):
        frame[c + "_std"] = 1.0
    frame["n_samples"] = np.int32(50)
    frame["t_start_s"] = 10.0 * frame["point_id"]
    frame["t_end_s"] = frame["t_start_s"] + 5.0
    return frame


REJECTED = {"motor_01": {"speed unstable": 3, "too short": 2}, "gen_01": {"power unstable": 4}}
CLOCKS = {"motor_01": (1.234, 41.0), "gen_01": (-0.75, -12.5)}


def write_store(store: Path, operator: str = "J. Doe", seed: int = 1) -> pd.DataFrame:
    """A store (docs/schemas.md §2) of two sessions; returns its points."""
    points = _points(np.random.default_rng(seed))
    for sub in ("points", "rejected"):
        (store / sub).mkdir(parents=True, exist_ok=True)
    sessions = {}
    for sid, group in points.groupby("session_id"):
        group.to_parquet(store / "points" / f"{sid}.parquet", index=False)
        rej = [(sid, 1.0 * k, 2.0 * k, reason) for reason, n in REJECTED[sid].items()
               for k in range(n)]
        pd.DataFrame(rej, columns=["session_id", "t_start_s", "t_end_s", "reason"]).to_parquet(
            store / "rejected" / f"{sid}.parquet", index=False)
        mode = str(group["mode"].iloc[0])
        sessions[sid] = {
            "files": {f"{sid}/daq.csv": "ab" * 32, f"{sid}/analyzer.csv": "cd" * 32},
            "kind": "timeseries", "mode": mode, "n_points": len(group),
            "points_per_quadrant": {q: int((group["quadrant"] == q).sum())
                                    for q in ("motor", "generator")},
            "rejected": REJECTED[sid],
            "clock_offset_s": CLOCKS[sid][0], "clock_drift_ppm": CLOCKS[sid][1],
            "metadata": {"session_id": sid, "kind": "timeseries", "mode": mode,
                         "operator": operator, "date": "2013-04-17", "gear_ratio": 3.0,
                         "measured_side": "drum", "daq": {"file": "daq.csv", "format": "csv"},
                         "analyzer": {"file": "analyzer.csv", "format": "vendor_csv"},
                         "sensors": {"torque_range_nm": 100.0}},
            "ingested_at": "2026-01-01T00:00:00Z",
        }
    manifest = {"schema": "drivebench.store", "schema_version": 1, "sessions": sessions}
    (store / "manifest.json").write_text(json.dumps(manifest, indent=1), encoding="utf-8")
    return points


def write_fit(fit: Path, points: pd.DataFrame) -> PowerModel:
    """Fit outputs (docs/schemas.md §3, §4): the paper's model with a known covariance."""
    fit.mkdir(parents=True, exist_ok=True)
    paper = paper_model()
    model = PowerModel(
        terms=paper.terms, coefficients_rpm=paper.coefficients_rpm,
        covariance_rpm=tuple(map(tuple, np.diag(np.square(SE_RPM)))),
        nominal_power_w=8200.0, name="test model (paper Table I)",
        masking={"mech_frac": 0.02, "elec_frac": 0.02,
                 "rules": ["negative efficiency -> 0", "|P_mech| < 0.02 * 8200 W -> masked"]},
        provenance={"command_line": ["bench", "fit", "--store", "s", "--out", "f"]},
        drive={"nominal_power_w": 8200.0, "max_speed_rpm": 3000.0, "max_torque_nm": 78.0,
               "source": "test rating"},
    )
    s, t = np.meshgrid(np.arange(-3000, 1501, 100.0), np.arange(0, 79, 2.0), indexing="ij")
    s, t = s.ravel(), t.ravel()
    p_mech = s * 2 * np.pi / 60 * t
    p_elec = paper.p_elec_w(s, t)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(p_mech > 0, p_mech / p_elec, p_elec / p_mech)
    near = (np.abs(p_mech) < 164.0) | (np.abs(p_elec) < 164.0)
    status = np.where(near, "near_axis", np.where(eta < 0, "negative", "ok"))
    eta = np.where(near, np.nan, np.clip(eta, 0.0, None))
    emap = pd.DataFrame({"speed_rpm": s, "torque_nm": t,
                         "quadrant": np.where(p_mech > 0, "motor", "generator"),
                         "in_hull": True, "p_mech_w": p_mech, "p_elec_w": p_elec, "eta": eta,
                         "status": status})
    selection = pd.DataFrame({"candidate": ["paper eq. 4", "order 3"], "n_terms": [4, 10],
                              "cv_rmse_w": [121.0, 123.5], "bic": [100.0, 140.0],
                              "chosen": [True, False]})
    run = Provenance.start(["bench", "fit", "--store", "s"])
    summary = {"provenance": run.header(),
               "efficiency": {
        "band_shares": [{"quadrant": "motor", "band": "0.80-0.85", "area_share": 0.25},
                        {"quadrant": "generator", "band": "0.80-0.85", "area_share": 0.5}],
        "peak": {"motor": {"map": {"speed_rpm": 1500.0, "torque_nm": 40.0, "eta": 0.93}}}}}
    with output_folder(fit, "fit", provenance=run) as stage:
        write_fit_files(stage, FitContents(model, emap, {}, selection, {}, summary),
                        lambda _: [])
    return model


def _cycle(scenario: str, kind: str, wind: float) -> pd.DataFrame:
    """An analytic cycle: n points at t_k = k T / n (k = 1..n), weight 1/n each.

    P_elec = mean + A sin(2 pi t / T): the point rule integrates the sine to exactly 0.
    """
    n = 60
    t = CYCLE_PERIOD_S * np.arange(1, n + 1) / n
    phase = 2 * np.pi * t / CYCLE_PERIOD_S
    speed = -1200.0 * np.sin(phase)
    torque = 40.0 + 30.0 * np.sin(phase)
    return pd.DataFrame({
        "scenario": scenario, "kind": kind, "wind_speed_m_s": wind, "time_s": t,
        "weight": np.full(n, 1.0 / n), "l_m": 200.0 + 20.0 * np.cos(phase),
        "speed_rpm": speed, "torque_nm": torque,
        "p_elec_w": CYCLE_MEAN_P_W + 3000.0 * np.sin(phase),
        "p_mech_w": 2.0 * CYCLE_MEAN_P_W + 3500.0 * np.sin(phase),
    })


def write_optimize(opt: Path, model_sha256: str = "",
                   claims: pd.DataFrame | None = None) -> pd.DataFrame:
    """Optimize outputs (docs/schemas.md §5): 20 scenarios, ``mech-free`` at 8.5 m/s failed;
    ``claims``: the paper comparison (default: one agreeing statement)."""
    opt.mkdir(parents=True, exist_ok=True)
    rows, trajs = [], []
    for kind in KINDS:
        for w in WINDS:
            name = f"{kind}-{w:.1f}"
            ok = not (kind == "mech-free" and w == 8.5)
            p_e = -100.0 * (w - 5.0) - (50.0 if kind.startswith("elec") else 0.0)
            rows.append({"scenario": name, "kind": kind,
                         "objective": "electrical" if kind.startswith("elec") else "mechanical",
                         "drive_limits": kind.endswith("lim"), "wind_speed_m_s": w,
                         "success": ok, "status": "Solve_Succeeded" if ok else FAILED_STATUS,
                         "iterations": 12, "period_s": CYCLE_PERIOD_S if ok else math.nan,
                         "avg_p_elec_w": p_e if ok else math.nan,
                         "avg_p_mech_w": 2 * p_e - 300.0 if ok else math.nan,
                         "peak_speed_rpm": 900.0 if ok else math.nan,
                         "peak_torque_nm": 40.0 if ok else math.nan})
            if ok and name in ("elec-free-10.0", "mech-free-10.0", "elec-lim-5.5",
                               "elec-lim-10.0", "mech-lim-10.0"):
                trajs.append(_cycle(name, kind, w))
    summary = pd.DataFrame(rows)
    if claims is None:
        claims = pd.DataFrame({"claim_id": ["fig3-energy"],
                               "statement": ["Fig. 3 cycle nets +827 J"], "paper": ["827 J"],
                               "ours": ["827 J"], "verdict": ["agrees"], "note": [""]})
    write_sweep_folder(
        opt, Provenance.start(["bench", "optimize", "--wind-grid", "4:10:1.5"]),
        summary=summary, trajectories=pd.concat(trajs, ignore_index=True), system=None,
        claims=claims, manifest={
            "wind_speeds_m_s": list(WINDS),
            "drive_model": {"path": "fit/power_model.json", "model_sha256": model_sha256,
                            "name": "test model"},
            "cut_in": [{"kind": "elec-lim", "cut_in_m_s": 4.7947, "bracket_lo_m_s": 4.75,
                        "bracket_hi_m_s": 4.796875, "status": "found"}],
            "trust": {"mesh": [], "simulation": []}})
    return summary


def rewrite_optimize(src: Path, dst: Path, *, summary: pd.DataFrame | None = None,
                     trust: dict | None = None, drive: dict | None = None,
                     trajectories: pd.DataFrame | None = None) -> Path:
    """A copy of the optimize folder ``src`` in ``dst``, written whole by the sweep's writer
    (a new run of the same command line), with ``summary`` or the manifest's ``trust``
    checks replaced, or keys of its ``[drive]`` in force (``sections``, and the bound values
    they are) changed."""
    manifest = read_manifest(src)
    body = {k: v for k, v in manifest.items()
            if k not in ("schema", "schema_version", "provenance", "files")}
    if trust is not None:
        body["trust"] = trust
    if drive is not None:
        given = {**((body.get("sections") or {}).get("drive") or {}), **drive}
        flown = dataclasses.replace(Drive(), **{
            k: tuple(v) if isinstance(v, list) else v for k, v in given.items()})
        body["sections"] = {**(body.get("sections") or {}), "drive": flown.keys()}
        body["bound_values"] = {**(body.get("bound_values") or {}), **bound_values(flown)}
    write_sweep_folder(dst, Provenance.start(manifest["provenance"]["command_line"]),
                       summary=read_summary(src / SUMMARY_FILE) if summary is None else summary,
                       trajectories=(read_trajectories(src) if trajectories is None
                                     else trajectories), manifest=body, system=None,
                       claims=read_claims(src))
    return dst


@pytest.fixture(scope="module")
def full_inputs(tmp_path_factory) -> dict:
    """All three stages' outputs in one temp folder (module scope: built once, read only)."""
    root = tmp_path_factory.mktemp("report_inputs")
    points = write_store(root / "store")
    model = write_fit(root / "fit", points)
    summary = write_optimize(root / "opt", model.sha256)
    dirs = (root / "store", root / "fit", root / "opt")
    context = build_context(*dirs, ["bench", "report", "--out", "x.html"])
    report = write_text_atomic(root / "report.html", render(context))
    return {"root": root, "points": points, "model": model, "summary": summary,
            "dirs": dirs, "context": context, "report": report}


# ---------------------------------------------------------------- unit checks
def test_campaign_counts_rejections_and_clocks(full_inputs):
    ctx = full_inputs["context"]
    camp = ctx["campaign"]
    pts = full_inputs["points"]
    # exact counts: the report must show what the files hold, no tolerance
    assert camp["totals"]["motor"] == int((pts["quadrant"] == "motor").sum())
    assert camp["totals"]["generator"] == int((pts["quadrant"] == "generator").sum())
    assert camp["totals"]["rejected"] == 9
    reasons = {r["reason"]: r["count"] for r in camp["rejected_reasons"]}
    assert reasons == {"speed unstable": 3, "too short": 2, "power unstable": 4}
    rows = {s["session_id"]: s for s in camp["sessions"]}
    assert rows["motor_01"]["clock_offset_s"] == "1.234"
    assert rows["gen_01"]["clock_drift_ppm"] == "-12.5"
    assert camp["missing"] == []


def test_table_i_intervals_and_residuals(full_inputs):
    ctx = full_inputs["context"]
    power = ctx["power"]
    a1 = next(r for r in power["coefficients"] if r["symbol"] == "a1")
    c = paper_model().coefficients_rpm[1]
    lo, hi = c - 1.959964 * SE_RPM[1], c + 1.959964 * SE_RPM[1]
    # hand calculation of c +- 1.96 se, formatted to 5 significant digits
    assert a1["ci95"] == f"[{lo:.5g}, {hi:.5g}]"
    assert a1["diff_pct"] == "0.0"  # the model is the paper's own
    stats = {r["name"]: r for r in power["statistics"]}
    sd = float(stats["std of residual"]["value"].split()[0])
    # the points carry N(0, 120 W) noise on the exact model: n ~ 250, so the sample sd
    # is within ~4.5 % (1 sigma = 1/sqrt(2n)); 15 % is > 3 sigma
    assert sd == pytest.approx(NOISE_W, rel=0.15)
    assert power["power_map"] is not None and power["residuals"] is not None


def test_table_ii_shows_failed_and_excludes_it(full_inputs):
    ctx = full_inputs["context"]
    opt = ctx["optimization"]
    assert opt["n_scenarios"] == 20 and opt["n_failed"] == 1
    t2 = opt["table_ii"]
    row85 = next(r for r in t2["rows"] if r["wind"] == "8.5")
    cell = row85["cells"][t2["kinds"].index("mech-free")]
    assert cell["failed"] == FAILED_STATUS
    row4 = next(r for r in t2["rows"] if r["wind"] == "4")
    # elec-lim at 4 m/s: p = -100 * (4 - 5) - 50 = +50 W, p_mech = 2 p - 300 = -200 W
    assert row4["cells"][0] == {"elec": "50", "mech": "-200", "failed": None}
    assert "1 failed, not shown" in str(opt["fig8a"])
    html = full_inputs["report"].read_text(encoding="utf-8")
    assert f"failed ({FAILED_STATUS})" in html
    # the sweep's manifest names the fitted model's canonical hash: the report confirms it
    assert dict(opt["run"])["same model as section 3 (power model)"] == "yes"
    assert opt["cut_in"][0]["cut_in"] == "4.79" and opt["cut_in"][0]["label"] == (
        "elec. optimized, constrained")
    assert opt["claims"][0]["verdict"] == "agrees"
    assert dict(ctx["headline"])["optimizations"] == "19 of 20 converged"


def test_report_says_the_paper_comparison_does_not_apply(full_inputs, tmp_path):
    """A sweep of another system: claims.csv holds only "does not apply" rows (as
    optimize.analysis.claims writes them); the report says so instead of a table."""
    store, fit, _ = full_inputs["dirs"]
    other = tmp_path / "opt"
    note = ("system 'ap2' is not the paper's: its statements are about another kite, so the "
            "paper comparison does not apply")
    write_optimize(other, claims=pd.DataFrame({
        "claim_id": ["fig3-energy", "fig3-period"], "statement": ["a", "b"],
        "paper": ["827 J", "6 s"], "ours": ["n/a", "n/a"],
        "verdict": ["does not apply"] * 2, "note": [note] * 2}))
    html = render(build_context(store, fit, other, ["bench", "report"]))
    escaped = note.replace("'", "&#39;")
    assert f"Paper comparison: {escaped}." in html  # said once, by the note
    assert '<table id="claims">' not in html


def test_cycle_energy_matches_the_analytic_net_energy(full_inputs):
    cyc = _cycle("x", "elec-lim", 5.5)
    e = CYCLE_PERIOD_S * cycle_quadrature(cyc["weight"], cyc["p_elec_w"], cumulative=True)
    # point rule on a full period integrates the sine exactly: net = mean * T = -827 J
    assert e[-1] == pytest.approx(-827.0, abs=1e-9)
    assert CYCLE_PERIOD_S * cycle_quadrature(cyc["weight"], cyc["p_elec_w"]) == pytest.approx(
        -827.0, abs=1e-9)
    # the cycle object (shuffled rows: it sorts them) says the same, and closes at t = 0
    cycle = Cycle.of(cyc.sample(frac=1.0, random_state=1))
    assert (cycle.scenario, cycle.kind, cycle.wind_speed_m_s) == ("x", "elec-lim", 5.5)
    assert cycle.period_s == pytest.approx(CYCLE_PERIOD_S, rel=1e-12)
    assert cycle.average("p_elec_w") * cycle.period_s == pytest.approx(-827.0, abs=1e-9)
    energy = cycle.energy_j("p_elec_w")
    assert energy[0] == 0.0 and energy[-1] == pytest.approx(-827.0, abs=1e-9)
    assert len(energy) == len(cycle.closed()) == len(cyc) + 1
    assert cycle.closed()["time_s"].iloc[0] == 0.0
    ctx = full_inputs["context"]
    assert "net -827 J" in str(ctx["optimization"]["fig3"])


def test_efficiency_grid_draws_masked_nodes_white():
    emap = pd.DataFrame({"speed_rpm": [-10.0, 10.0, -10.0, 10.0],
                         "torque_nm": [1.0, 1.0, 2.0, 2.0],
                         "eta": [np.nan, 0.9, np.nan, 0.5],
                         "status": ["near_axis", "ok", "outside_hull", "ok"]})
    speed, torque, eta = efficiency_grid(emap)
    assert list(speed) == [-10.0, 10.0] and list(torque) == [1.0, 2.0]
    # near-axis -> 0 (white, the paper's rule); outside the hull stays NaN (not drawn)
    assert eta[0, 0] == 0.0 and eta[0, 1] == 0.9
    assert math.isnan(eta[1, 0]) and eta[1, 1] == 0.5


def test_svg_escapes_metadata_text():
    fig = new_figure()
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1], label=XSS + " -- $x$ & more")
    ax.set_title(XSS)
    ax.legend()
    svg = str(to_svg(fig, "escape-test"))
    assert "<script" not in svg
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in svg
    ET.fromstring(svg)  # well-formed XML: nothing broke out of a <text> or a comment


def test_provenance_hashes_every_input(full_inputs):
    ctx = full_inputs["context"]
    prov = ctx["provenance"]
    assert prov["missing"] == []
    for rec in prov["inputs"]:
        assert rec["sha256"] == hashlib.sha256(Path(rec["path"]).read_bytes()).hexdigest()
    names = {Path(r["path"]).name for r in prov["inputs"]}
    assert {"manifest.json", "power_model.json", "summary.parquet", "claims.csv"} <= names
    commands = {c["stage"]: c["command"] for c in prov["commands"]}
    assert {"report", "fit", "optimize"} <= set(commands)
    assert commands["optimize"] == "bench optimize --wind-grid 4:10:1.5"
    assert {p for p, _ in prov["packages"]} >= {"numpy", "casadi", "drivebench"}


# ------------------------------------------------------------- CLI behaviour
def test_partial_inputs_render_and_say_what_is_missing(tmp_path, capsys):
    write_store(tmp_path / "store")
    out = tmp_path / "r.html"
    (tmp_path / "noopt").mkdir()  # a folder without its files: those are missing inputs
    code = main(["report", "--store", str(tmp_path / "store"), "--fit", str(tmp_path / "nofit"),
                 "--optimize", str(tmp_path / "noopt"), "--out", str(out)])
    assert code == 0
    umask = os.umask(0)
    os.umask(umask)
    # a normal new file (not the temp file's private 0600): the report is meant to be shared
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask
    printed = capsys.readouterr().out
    assert str(out.resolve()) in printed and re.search(r"written in \d+\.\d s", printed)
    html = out.read_text(encoding="utf-8")
    for missing in ("noopt/summary.parquet", "noopt/claims.csv"):
        assert f"not available: <code>{tmp_path / missing}</code> missing" in html
    # issue 49: a stage not run (no folder) is said once per section, not as missing
    # files nor among the missing inputs at the top
    assert f"Not run: bench fit (no {tmp_path / 'nofit'})." in html
    assert "nofit/power_model.json</code> missing" not in html
    top = html[:html.index("<main>")]
    assert "noopt/summary.parquet" in top and "nofit/" not in top.split("Not found:")[0]
    assert 'id="sessions"' in html  # the campaign section is still there


def test_bad_manifest_is_an_input_error_and_keeps_the_old_report(tmp_path, capsys):
    write_store(tmp_path / "store")
    out = tmp_path / "r.html"
    previous = '<!DOCTYPE html>\n<meta name="generator" content="drivebench report">previous'
    out.write_text(previous, encoding="utf-8")
    (tmp_path / "store" / "manifest.json").write_text('{"sessions": {,}}', encoding="utf-8")
    code = main(["report", "--store", str(tmp_path / "store"), "--fit", str(tmp_path / "f"),
                 "--optimize", str(tmp_path / "o"), "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err
    assert "manifest.json:1: not valid JSON" in err
    assert out.read_text(encoding="utf-8") == previous
    # no temporary file left; the writer's lock file (kernel.locking) stays
    assert [p.name for p in tmp_path.glob(".r.html.*")] in ([], [".r.html.lock"])


def test_report_is_small_and_offline(full_inputs):
    out = full_inputs["report"]
    html = out.read_text(encoding="utf-8")
    assert out.stat().st_size < 10e6
    # no external resource of any kind: every src/href is a data URI or an in-page anchor
    for attr in re.findall(r'(?:src|href)\s*=\s*"([^"]*)"', html):
        assert attr.startswith(("data:", "#")), attr
    assert "http://" not in html.replace("http://www.w3.org/", "")
    assert "https://" not in html


# -------------------------------------------------------------------- browser
CHROMIUM = Path("/usr/bin/chromium")
BROWSER_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run"]


@pytest.fixture(scope="module")
def browser():
    """Debian's chromium driven by playwright; skips (saying why) where either is absent."""
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="playwright not installed (dev extra)")
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} missing: `make browser` installs Debian's chromium (needs root)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=BROWSER_ARGS)
        yield b
        b.close()


def _load(browser, path: Path) -> dict:
    """Open ``path`` headless; record console errors, dialogs and every request."""
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    seen = {"errors": [], "dialogs": [], "requests": [], "page": page}
    page.on("console", lambda m: seen["errors"].append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: seen["errors"].append(str(e)))
    page.on("dialog", lambda d: (seen["dialogs"].append(d.message), d.dismiss()))

    def route(r):
        seen["requests"].append(r.request.url)
        if r.request.url.startswith(("file:", "data:")):
            r.continue_()
        else:
            r.abort()

    page.route("**/*", route)
    page.goto(path.resolve().as_uri(), wait_until="load")
    return seen


def test_browser_renders_offline_without_errors(browser, full_inputs, tmp_path):
    out = full_inputs["report"]
    seen = _load(browser, out)
    page = seen["page"]
    assert seen["errors"] == []
    assert seen["requests"] == [out.resolve().as_uri()]  # only the page itself
    widths = page.eval_on_selector_all("img", "els => els.map(e => e.complete && e.naturalWidth)")
    assert all(w and w > 0 for w in widths)
    boxes = page.eval_on_selector_all(
        "svg", "els => els.map(e => {const r = e.getBoundingClientRect();"
               " return r.width * r.height})")
    assert len(boxes) >= 8 and min(boxes) > 0  # every figure of the full report laid out
    shot = tmp_path / "shot.png"
    page.screenshot(path=str(shot), full_page=False)
    from matplotlib.image import imread
    pixels = imread(shot)[..., :3]
    # a blank page has zero variance; text, tables and figures give a clearly positive one
    assert pixels.std() > 0.05
    page.close()


def test_browser_xss_operator_is_shown_as_text_and_never_runs(browser, tmp_path):
    write_store(tmp_path / "store", operator=XSS)
    out = build_report(tmp_path / "store", tmp_path / "f", tmp_path / "o",
                       tmp_path / "xss.html", ["bench"])
    raw = out.read_text(encoding="utf-8")
    assert XSS not in raw and "&lt;script&gt;alert(1)&lt;/script&gt;" in raw
    seen = _load(browser, out)
    page = seen["page"]
    cells = page.eval_on_selector_all("td.operator", "els => els.map(e => e.textContent)")
    assert cells and all(c == XSS for c in cells)  # shown literally, as text
    assert seen["dialogs"] == []  # alert() never ran
    assert page.evaluate("document.querySelectorAll('script').length") == 0
    assert seen["errors"] == []
    page.close()


# ------------------------------------------------------------ with the real fit
def test_report_reads_the_real_fit_outputs(tmp_path):
    """`bench fit` on a hand-written store, then the report: the fit's own figures show."""
    points = write_store(tmp_path / "store")
    assert main(["fit", "--store", str(tmp_path / "store"), "--out", str(tmp_path / "fit"),
                 "--folds", "2"]) == 0
    ctx = build_context(tmp_path / "store", tmp_path / "fit", tmp_path / "opt", ["bench"])
    fit_summary = json.loads((tmp_path / "fit" / "fit_summary.json").read_text("utf-8"))
    power, eff = ctx["power"], ctx["efficiency"]
    assert power["missing"] == [] and eff["missing"] == []
    assert power["interval_note"].startswith("95 % intervals as computed by the fit")
    # residual sd at the store's points: ours (measured - model) equals the fit's own figure;
    # both are the same arithmetic on the same numbers, so only rounding to 0.1 W differs
    ours = float(next(r for r in power["statistics"] if r["name"] == "std of residual")
                 ["value"].split()[0])
    assert ours == pytest.approx(fit_summary["statistics"]["residuals"]["all"]["std_w"], abs=0.06)
    assert ours == pytest.approx(NOISE_W, rel=0.15)  # and the noise we put in (see above)
    # the fit recovers the paper's a1 (the truth of the synthetic points) within 5 %
    a1 = next(r for r in power["coefficients"] if r["symbol"] == "a1")
    assert abs(float(a1["diff_pct"])) < 5.0
    assert eff["figure"] is not None and eff["bands"] is not None and eff["peaks"]
    assert any("negative efficiency" in r for r in eff["rules"])
    assert power["selection"]["rows"] and power["extra_terms"] is not None
    assert len(points) == ctx["campaign"]["totals"]["points"]


def test_cycles_outside_the_validity_domain_are_listed():
    from reports.optimization_section import domain_rows
    summary = pd.DataFrame({
        "scenario": ["elec-lim-5.5", "elec-lim-7.0", "mech-free-8.5"],
        "success": [True, True, False],
        "outside_domain_time_frac": [0.5, 0.0, math.nan],
        "outside_worst_speed_rpm": [-1200.0, math.nan, math.nan],
        "outside_worst_torque_nm": [60.0, math.nan, math.nan],
        "outside_worst_distance": [0.8333, 0.0, math.nan]})
    rows = domain_rows(summary)
    assert rows == ["elec-lim-5.5: 50.0 % of the cycle time outside the drive model's validity "
                    "domain; worst at -1200 rpm, 60.0 N m (distance 0.833 of the drive rating)"]
    inside = summary.assign(outside_domain_time_frac=[0.0, 0.0, math.nan])
    assert domain_rows(inside) == []
    assert domain_rows(summary.drop(columns="outside_domain_time_frac")) is None


def test_fig9_draws_the_drive_envelope_the_sweep_flew_with(full_inputs, tmp_path):
    """A sweep whose drive stated a base speed of 1000 rpm: the map under the limited
    cycles carries the envelope (78 N m up to 1000 rpm, 78 x 1000 / |n| above); a sweep
    without one draws none."""
    from optimize.model.envelope import envelope_curve
    from reports.optimization_section import flown_envelope

    store, fit, opt = full_inputs["dirs"]
    limits = {"max_speed_rpm": 1500.0, "max_torque_nm": 78.0, "base_speed_rpm": 1000.0,
              "envelope_speed_rpm": None, "envelope_torque_nm": None}
    other = rewrite_optimize(opt, tmp_path / "opt", drive=limits)
    speed, torque = flown_envelope(read_manifest(other))
    assert np.interp([-1500.0, -500.0, 0.0, 1200.0], speed, torque) == pytest.approx(
        [52.0, 78.0, 78.0, 65.0], abs=1e-9)
    html = render(build_context(store, fit, other, ["bench", "report"]))
    assert 'id="drive-envelope"' in html
    assert 'id="drive-envelope"' not in full_inputs["report"].read_text(encoding="utf-8")
    table = {"max_speed_rpm": 1500.0, "max_torque_nm": 78.0, "base_speed_rpm": None,
             "envelope_speed_rpm": (0.0, 1000.0, 1500.0), "envelope_torque_nm": (78.0, 78.0, 40.0)}
    speed, torque = envelope_curve(Drive(**table))
    assert np.interp([1250.0, -1250.0], speed, torque) == pytest.approx([59.0, 59.0])


def test_fig3_shows_the_winding_temperature_over_the_cycle_and_its_margin(full_inputs,
                                                                          tmp_path):
    """A sweep whose cycles carried the winding temperature: the Fig. 3 analogue gains its
    panel, with the limit and the margin (limit - peak) said in the legend."""
    store, fit, opt = full_inputs["dirs"]
    traj = read_trajectories(opt)
    phase = 2 * np.pi * traj["time_s"] / CYCLE_PERIOD_S
    traj["theta_winding_c"] = 44.0 + 0.5 * np.sin(phase)  # peak 44.5 degC
    other = rewrite_optimize(opt, tmp_path / "opt", trajectories=traj,
                             drive={"max_winding_temperature_c": 45.0})
    html = render(build_context(store, fit, other, ["bench", "report"]))
    assert 'id="winding-temperature"' in html
    assert "limit 45 degC (margin 0.50 K)" in html
    assert 'id="winding-temperature"' not in full_inputs["report"].read_text(encoding="utf-8")


def test_the_thermal_tables_show_the_ladder_and_the_held_out_check():
    """A two-node thermal block as bench fit writes it: every node's capacity and
    resistance with its interval, each candidate's held-out RMS, the choice."""
    from kernel.thermal_model import ThermalModel
    from reports.model_section import thermal_tables
    node = {"c_j_per_k": 1500.0, "c_j_per_k_ci95": [1400.0, 1600.0], "r_k_per_w": 0.015,
            "r_k_per_w_ci95": [0.014, 0.016]}
    thermal = {"nodes": 2, "r_th_k_per_w": 0.05, "r_th_k_per_w_ci95": [0.048, 0.052],
               "tau_th_s": 400.0, "tau_th_s_ci95": [380.0, 420.0], "c_th_j_per_k": 8000.0,
               "copper_temp_coeff_per_k": 0.0039, "copper_temp_coeff_per_k_ci95": [0.0035, 0.0043],
               "ladder": [{"node": "winding", **node}, {"node": "housing", **node}],
               "selection": {"rule": "one-SE", "candidates": [
                   {"nodes": 1, "cv_rms_k": 2.5, "cv_rms_k_se": 0.2,
                    "held_out_rms_k": {"a": 2.3, "b": 2.7}},
                   {"nodes": 2, "cv_rms_k": 0.4, "cv_rms_k_se": 0.05,
                    "held_out_rms_k": {"a": 0.35, "b": 0.45}}]}}
    tables = thermal_tables(ThermalModel.from_dict(thermal))
    rows = {r[0]: r[1:] for r in tables["parameters"]["rows"]}
    assert rows["housing: heat capacity"] == ["1500", "[1400, 1600]", "J/K"]
    assert rows["winding: resistance outwards"][0] == "0.015"
    assert [r[:2] for r in tables["check"]["rows"]] == [["1", "2.5"], ["2", "0.4"]]
    assert tables["check"]["notes"][0].startswith("chosen: 2 node(s)")
    assert thermal_tables(None) is None
