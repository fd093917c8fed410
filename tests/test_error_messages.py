"""Every error names the option, key or file it is about: a table of bad inputs and the
message each must give (exit 2, nothing solved), and a stored point whose efficiency is
outside [0, 1] is flagged with its reason, never kept silently."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from ingest_fixtures import make_points_session

from bench.ingest.checks import efficiency_flags
from bench.store.manifest import read_manifest
from drivebench.cli import main
from kernel.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
SITE = ["--weibull-k", "2", "--mean-speed", "6"]


def _gravity_file(tmp: Path) -> Path:
    text = (ROOT / "optimize/data/systems/highwind.toml").read_text()
    lines = [("gravity_m_s2 = 98.1" if ln.startswith("gravity_m_s2") else ln)
             for ln in text.splitlines()]
    path = tmp / "grav.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _model_100x(tmp: Path) -> Path:
    data = json.loads((ROOT / "optimize/data/paper_drive_model.json").read_text())
    for key in ("max_torque_nm", "nominal_power_w"):
        data["drive"][key] *= 100
    data["nominal_power_w"] *= 100
    path = tmp / "model100.json"
    path.write_text(json.dumps(data))
    return path


def _losses_file(tmp: Path) -> Path:
    """A system file whose [drive] losses names a fit folder's summary, not its model."""
    fit = tmp / "fit"
    fit.mkdir()
    (fit / "fit_summary.json").write_text(json.dumps(
        {"schema": "drivebench.fit_summary", "provenance": {"run_id": "0123abcd"}}))
    text = (ROOT / "optimize/data/systems/highwind.toml").read_text()
    path = fit / "system.toml"
    path.write_text(text.replace("[drive]\n", '[drive]\nlosses = "fit_summary.json"\n', 1))
    return path


def _thermal_model(tmp: Path, edit) -> Path:
    """The paper's model with a one-node thermal block, ``edit(block)`` applied."""
    data = json.loads((ROOT / "optimize/data/paper_drive_model.json").read_text())
    block = {"nodes": 2, "r_th_k_per_w": 0.05, "tau_th_s": 900.0, "c_th_j_per_k": 18000.0,
             "ladder": [{"c_j_per_k": 6000.0, "r_k_per_w": 0.02},
                        {"c_j_per_k": 30000.0, "r_k_per_w": 0.03}],
             "copper_temp_coeff_per_k": 0.00393, "theta_ref_c": 20.0, "ambient_c": 25.0}
    edit(block)
    data["schema_version"] = 3
    data["thermal"] = block
    path = tmp / "thermal.json"
    path.write_text(json.dumps(data))
    return path


def _refusing_client(*args, **kwargs):
    raise OSError("Timed out trying to connect to tcp://127.0.0.1:1 after 20 s")


#: (argv built from tmp_path, what the message must hold, what it must not)
CASES = {
    "size --wind-grid 7": (
        lambda t: ["size", "--wind-grid", "7", "--scales", "1", "--out", str(t / "s"), *SITE],
        ["--wind-grid 7: one wind speed gives no AEP curve to integrate"], ["<input>"]),
    "--cycles 0": (
        lambda t: ["cycle", "export", "--optimize", str(t / "opt"), "--scenario", "x",
                   "--cycles", "0", "--out", str(t / "p.csv")],
        ["--cycles 0: not a whole number >= 1"], ["--n-cycles"]),
    "--store nowhere": (
        lambda t: ["cycle", "verify", "--store", str(t / "nowhere"), "--optimize",
                   str(t / "opt"), "--out", str(t / "v")],
        ["nowhere: option --store: not found"], ["0 cycle-run sessions"]),
    "implausible gravity": (
        lambda t: ["optimize", "--system", str(_gravity_file(t)), "--wind-grid", "7",
                   "--out", str(t / "o")],
        ["grav.toml: [wind] gravity_m_s2: gravity 98.1 is outside"], ["mass_kg"]),
    "--drive-model 100x off": (
        lambda t: ["optimize", "--drive-model", str(_model_100x(t)), "--wind-grid", "7",
                   "--out", str(t / "o")],
        ["model100.json: column 'drive': its drive rating", "--drive-model"],
        ["highwind.toml: [drive]"]),
    "unreachable scheduler": (
        lambda t: ["optimize", "--scheduler", "tcp://127.0.0.1:1", "--wind-grid", "7",
                   "--scenarios", "elec-lim", "--no-claims", "--out", str(t / "o")],
        ["--scheduler 'tcp://127.0.0.1:1': "], ["<input>"]),
    "[drive] losses names a fit summary": (
        lambda t: ["optimize", "--system", str(_losses_file(t)), "--wind-grid", "7",
                   "--out", str(t / "o")],
        ["fit_summary.json: column 'schema': not a power model (schema "
         "'drivebench.fit_summary')"],
        ["run.json"]),
    "negative copper coefficient": (
        lambda t: ["optimize", "--drive-model", str(_thermal_model(
            t, lambda b: b.update(copper_temp_coeff_per_k=-0.004))), "--wind-grid", "7",
            "--out", str(t / "o")],
        ["thermal.json: field 'thermal.copper_temp_coeff_per_k': -0.004"], ["Traceback"]),
    "resistance contradicting its ladder": (
        lambda t: ["optimize", "--drive-model", str(_thermal_model(
            t, lambda b: b.update(r_th_k_per_w=0.5))), "--wind-grid", "7",
            "--out", str(t / "o")],
        ["thermal.json: field 'thermal.ladder': its resistances sum to 0.05 K/W, "
         "r_th_k_per_w is 0.5 K/W"], ["Traceback"]),
    "unknown scenario kind": (
        lambda t: ["optimize", "--scenarios", "elec-lim,fast", "--out", str(t / "o")],
        ["--scenarios"], ["<input>"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_names_what_it_is_about(case, tmp_path, capsys, monkeypatch):
    argv, must, must_not = CASES[case]
    if case == "unreachable scheduler":
        distributed = pytest.importorskip("distributed")
        monkeypatch.setattr(distributed, "Client", _refusing_client)
    code = main(argv(tmp_path))
    err = capsys.readouterr().err
    assert code == 2, err
    assert not (tmp_path / "o").exists() and not (tmp_path / "p.csv").exists()
    for text in must:
        assert text in err, (case, err)
    for text in must_not:
        assert text not in err, (case, err)


def test_a_message_without_a_file_begins_with_its_option():
    assert InputError(None, "--workers 0: not >= 1").describe() == "--workers 0: not >= 1"
    assert InputError("a.csv", "bad", line=3, column="x").describe() == \
        "a.csv:3: column 'x': bad"


def test_negative_efficiency_is_flagged_by_hand_numbers():
    """-1500 rpm, 2 N m: p_mech = -314.2 W; p_elec = +300 W: efficiency 300 / -314.2 = -0.955."""
    speed, torque = np.array([-1500.0, 1000.0]), np.array([2.0, 60.0])
    p_mech = speed * torque * np.pi / 30
    p_elec = np.array([300.0, 7000.0])
    (flag,) = efficiency_flags({"speed_rpm": speed, "torque_nm": torque, "p_mech_w": p_mech,
                                "p_elec_w": p_elec})
    assert f"efficiency {300 / p_mech[0]:.3g} outside [0, 1] at -1500 rpm" in flag


def test_ingest_flags_a_point_whose_efficiency_is_outside_0_1(tmp_path, capsys):
    """A table whose generator point draws 300 W at -1500 rpm, 2 N m (drum): kept and flagged
    in the manifest and the ingest summary."""
    camp = tmp_path / "camp"
    truth = make_points_session(camp, "table_01", seed=3)
    table = camp / "table_01" / "points.csv"
    row = f"{3 * -1500.0:.4f};{2.0 / 3:.5f};{0.3:.6f};0,5;500".replace(".", ",")
    table.write_text(table.read_text() + row + "\n")
    store = tmp_path / "store"
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    out = capsys.readouterr().out
    flags = read_manifest(store)["sessions"]["table_01"]["efficiency_flags"]
    # the fixture's own points with opposite power signs beyond 1 % of the largest |p_mech|
    # (paper losses above the shaft power at low generator speed), and the added one
    p_mech = np.append(truth["p_mech_w"], -1500.0 * 2.0 * np.pi / 30)
    p_elec = np.append(truth["p_elec_w"], 300.0)
    floor = 0.01 * np.max(np.abs(p_mech))
    expected = (p_mech * p_elec < 0) & (np.abs(p_mech) > floor) & (np.abs(p_elec) > floor)
    assert len(flags) == int(expected.sum()) >= 1
    assert any("outside [0, 1] at -1500 rpm, 2 N m" in f for f in flags)
    assert "FLAGGED point: table_01: efficiency" in out


def test_flagged_points_are_one_line_per_session_and_not_repeated_when_unchanged():
    # issue 42: 120 FLAGGED lines on every ingest, re-ingests of unchanged sessions included
    from bench.ingest.summary import format_summary

    flags = [f"efficiency -0.{k} outside [0, 1] at -1500 rpm" for k in range(1, 61)]
    entry = {"points_per_quadrant": {"motor": 1, "generator": 1}, "rejected": {},
             "kind": "points", "mode": "table", "n_points": 2, "efficiency_flags": flags,
             "torque_zero_offset_nm": 0.0}
    manifest = {"sessions": {"a": entry, "b": entry}}
    out = format_summary(["a", "b"], [], manifest)
    lines = [x for x in out.splitlines() if x.startswith("FLAGGED")]
    assert lines == [f"FLAGGED point: {s}: {flags[0]} and 59 more (manifest efficiency_flags)"
                     for s in ("a", "b")]
    assert "FLAGGED" not in format_summary([], ["a", "b"], manifest)


def test_envelope_limit_is_active_only_where_the_envelope_bounds():
    """A base speed of 1e9 rpm never bounds the torque: a cycle on its 78 N m torque limit
    is not on its envelope; with 1000 rpm, 55.7 N m at 1400 rpm is (78 x 1000 / 1400)."""
    from types import SimpleNamespace

    from kernel.drive import Drive
    from optimize.problem.drive_part import DrivePart
    from optimize.problem.part import near

    def envelope_active(base, speed, torque):
        limits = Drive(base_speed_rpm=base, max_torque_nm=78.0)
        ratio = DrivePart(None, None, SimpleNamespace(drive=limits), None).envelope_ratio(
            speed, torque)
        return ratio is not None and near(ratio, 1.0)

    speed, torque = np.array([500.0, 1400.0]), np.array([78.0, 78.0])
    assert not envelope_active(1e9, speed, torque)
    assert not envelope_active(1000.0, speed, np.array([78.0, 50.0]))
    assert envelope_active(1000.0, speed, np.array([78.0, 78.0 * 1000 / 1400]))


def test_an_unusable_compiled_code_cache_falls_back_naming_it(tmp_path, monkeypatch, caplog):
    """--codegen's cache under a path that is a file, or a damaged library in it: the
    function runs uncompiled, and the warning names the cache (no scenario fails)."""
    import casadi as ca

    from optimize.problem.transcriptions import codegen

    if codegen.compiler() is None:
        pytest.skip("no C compiler")
    x = ca.SX.sym("x")
    fn = ca.Function("cache_probe", [x], [x * x + 1.0])
    (tmp_path / "afile").write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "afile"))
    assert codegen.compiled(fn) is fn
    assert "afile/drivebench/casadi" in caplog.text and "runs uncompiled" in caplog.text
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    built = codegen.compiled(fn)
    assert built is not fn and float(built(3.0)) == 10.0
    for lib in (tmp_path / "cache").rglob("*.so"):  # the same library, damaged, elsewhere
        damaged = tmp_path / "damaged" / lib.relative_to(tmp_path / "cache")
        damaged.parent.mkdir(parents=True)
        damaged.write_bytes(b"damaged")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "damaged"))
    caplog.clear()
    # it records no hash of its build: named, compiled again, the right function loaded
    rebuilt = codegen.compiled(fn)
    assert rebuilt is not fn and float(rebuilt(3.0)) == 10.0
    assert "records no SHA-256 of its build" in caplog.text and "compiled again" in caplog.text
    # damaged in a folder that cannot be written: named, and the function runs uncompiled
    lib = next((tmp_path / "damaged").rglob("*.so"))
    (tmp_path / "new.so").write_bytes(b"damaged")  # a new file: the loaded one stays mapped
    os.replace(tmp_path / "new.so", lib)
    lib.parent.chmod(0o500)
    try:
        caplog.clear()
        if os.access(lib.parent, os.W_OK):  # root writes anyway: nothing to refuse it
            assert codegen.compiled(fn) is not fn
        else:
            assert codegen.compiled(fn) is fn and "cannot be used" in caplog.text
        assert "differs from the SHA-256 recorded at its build" in caplog.text
    finally:
        lib.parent.chmod(0o700)
