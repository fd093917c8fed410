"""The cycle verified is the cycle flown (issue 41): ``bench cycle verify`` refuses a sweep,
a power model or a profile header other than the one the session flew, naming both; a
cycle with invalid samples is rejected with its reason, never kept with NaN energies; a
profile's header keys that cannot be honoured are refused naming the key. Each case: the
command, its exit code, the key named, and the store as it was."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from bench.cycle_profile import BenchFrame, read_profile
from bench.ingest.pipeline import ingest
from bench.store.manifest import read_manifest
from bench.synth.cycle_session import CycleRunSpec, write_cycle_run
from cycle.export import ExportOptions, export_cycle
from cycle.provenance import trajectory_sha256
from cycle.verify_command import verify_cycles
from drivebench.cli import main
from kernel.errors import InputError
from kernel.output_folder import check_output_folder
from optimize.sweep_folder import read_manifest as read_sweep_manifest
from optimize.sweep_folder import read_trajectories
from tests.cycle_fixtures import copy_session, exact_e_mech_j, write_cycle_sweep

ROOT = Path(__file__).resolve().parent.parent
TRUTH = ROOT / "raw_measurements" / "truth.json"
FRAME = BenchFrame("motor", 3.0, 1, 1)


def _quiet(line: str) -> None:
    pass


@pytest.fixture(scope="module")
def trip(tmp_path_factory):
    """A sweep, another run of the same sweep, a profile of elec-lim-7.0 flown once
    (session ``cycle_s1``) and ingested."""
    base = tmp_path_factory.mktemp("provenance")
    model = write_cycle_sweep(base / "opt")
    write_cycle_sweep(base / "other")  # the same cycles, another run
    export_cycle(base / "opt", "elec-lim-7.0", base / "profile.csv",
                 ExportOptions(n_cycles=5, frame=FRAME))
    camp = base / "campaign"
    camp.mkdir()
    shutil.copy(ROOT / "raw_measurements" / "drive.toml", camp)
    run = dataclasses.replace(CycleRunSpec(), session_id="cycle_s1", seed=1)
    write_cycle_run(camp, base / "profile.csv", run, truth_path=TRUTH)
    ingest([camp], base / "store", progress=False, notify=_quiet)
    return base, model


def _verify(store: Path, opt: Path, out: Path) -> list[str]:
    return ["cycle", "verify", "--store", str(store), "--optimize", str(opt), "--out", str(out)]


def _copy(trip, tmp_path: Path, name: str, edit=None) -> tuple[Path, Path]:
    """A copy of the store, and a campaign holding a copy of the session under ``name``
    whose profile ``edit(text)`` changed."""
    return copy_session(trip[0], tmp_path, name, edit)


def _stored(store: Path) -> dict[str, bytes]:
    return {p.relative_to(store).as_posix(): p.read_bytes()
            for p in sorted(store.rglob("*")) if p.is_file() and p.name != ".lock"}


def test_the_round_trip_records_its_provenance(trip):
    """The profile's header names the sweep's run, its power model and the scenario's
    trajectory hash; ingest keeps them, and the set-points' own energy, which is the
    closed form's within 0.05 %."""
    base, model = trip
    header = read_profile(base / "profile.csv").header
    sweep = read_sweep_manifest(base / "opt")
    traj = read_trajectories(base / "opt")
    assert header["optimize_run_id"] == sweep["provenance"]["run_id"]
    assert header["power_model_sha256"] == model.sha256
    assert header["trajectory_sha256"] == trajectory_sha256(
        traj[traj["scenario"] == "elec-lim-7.0"])
    info = read_manifest(base / "store")["sessions"]["cycle_s1"]["cycles"]
    assert info["provenance"] == {k: header[k] for k in
                                  ("optimize_run_id", "power_model_sha256", "trajectory_sha256")}
    assert info["e_mech_profile_j"] == pytest.approx(exact_e_mech_j("elec-lim-7.0"), rel=5e-4)


def test_verify_refuses_another_sweep_naming_both_runs(trip, tmp_path, capsys):
    """The same scenarios of another run: exit 2, both run ids named, nothing written."""
    base, _ = trip
    out = tmp_path / "verify"
    assert main(_verify(base / "store", base / "other", out)) == 2
    err = capsys.readouterr().err
    mine = read_sweep_manifest(base / "other")["provenance"]["run_id"]
    flown = read_profile(base / "profile.csv").header["optimize_run_id"]
    assert "column 'optimize_run_id'" in err and "Traceback" not in err
    assert f"the sweep is run {mine[:12]}" in err and f"exported from run {flown[:12]}" in err
    assert flown in err and not out.exists()


def test_verify_refuses_another_power_model(trip, tmp_path):
    base, model = trip
    other = dataclasses.replace(model, coefficients_rpm=tuple(
        1.01 * c for c in model.coefficients_rpm))
    with pytest.raises(InputError, match="power_model_sha256.*the power model given is "
                       f"{other.sha256[:12]}.*exported with {model.sha256[:12]}"):
        verify_cycles(base / "store", base / "opt", tmp_path / "v", model=other)
    assert not (tmp_path / "v").exists()


def test_a_relabelled_profile_is_refused_by_verify(trip, tmp_path, capsys):
    """The header's scenario changed after the run (7.0 -> 5.5): ingest keeps it (its
    body is what flew), verify refuses it naming the scenario the body is."""
    store, camp = _copy(trip, tmp_path, "cycle_relabel",
                        lambda t: t.replace('scenario = "elec-lim-7.0"',
                                            'scenario = "elec-lim-5.5"'))
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    capsys.readouterr()
    argv = [*_verify(store, trip[0] / "opt", tmp_path / "v"), "--session", "cycle_relabel"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "column 'trajectory_sha256'" in err and "a relabelled profile" in err
    assert "names scenario 'elec-lim-5.5'" in err and "is that of scenario 'elec-lim-7.0'" in err


def test_a_relabelled_header_with_its_energy_is_refused_by_ingest(trip, tmp_path, capsys):
    """Scenario and e_mech_pred_j relabelled together: the set-points integrate to 7.0's
    energy; ingest refuses naming e_mech_pred_j, the store as it was."""
    e55 = exact_e_mech_j("elec-lim-5.5")

    def relabel(text: str) -> str:
        text = text.replace('scenario = "elec-lim-7.0"', 'scenario = "elec-lim-5.5"')
        return re.sub(r"# e_mech_pred_j = .*", f"# e_mech_pred_j = {e55!r}", text)

    store, camp = _copy(trip, tmp_path, "cycle_relabel", relabel)
    before = _stored(store)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "profile.csv: column 'e_mech_pred_j'" in err and f"{e55:.1f} J" in err
    assert _stored(store) == before


def test_a_forged_trajectory_hash_is_refused_by_the_energy(trip, tmp_path, capsys):
    """Scenario and trajectory_sha256 relabelled to 5.5's: the set-points' energy (7.0's)
    is not 5.5's, verify refuses naming both energies."""
    base, _ = trip
    traj = read_trajectories(base / "opt")
    h55 = trajectory_sha256(traj[traj["scenario"] == "elec-lim-5.5"])

    def relabel(text: str) -> str:
        text = text.replace('scenario = "elec-lim-7.0"', 'scenario = "elec-lim-5.5"')
        return re.sub(r"# trajectory_sha256 = .*", f'# trajectory_sha256 = "{h55}"', text)

    store, camp = _copy(trip, tmp_path, "cycle_forged", relabel)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    capsys.readouterr()
    assert main([*_verify(store, base / "opt", tmp_path / "v"), "--session",
                 "cycle_forged"]) == 2
    err = capsys.readouterr().err
    assert "column 'e_mech_j'" in err and "the profile flew another cycle" in err
    assert f"{exact_e_mech_j('elec-lim-5.5'):.1f} J" in err


def test_an_edited_body_is_refused_by_ingest(trip, tmp_path, capsys):
    def edit(text: str) -> str:
        lines = text.splitlines()
        row = lines[-400].split(",")
        row[1] = f"{float(row[1]) * 1.1:.3f}"
        lines[-400] = ",".join(row)
        return "\n".join(lines) + "\n"

    store, camp = _copy(trip, tmp_path, "cycle_edit", edit)
    before = _stored(store)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 2
    assert "column 'body_sha256'" in capsys.readouterr().err
    assert _stored(store) == before


def test_a_cycle_with_invalid_samples_is_rejected_with_its_reason(trip, tmp_path, capsys):
    """Three logged torques inside cycle 2 are not numbers: that cycle is rejected ("cycle
    with invalid samples", the samples counted), the others kept; verify's every figure is
    finite and over the kept cycles, their count stated."""
    base, _ = trip
    store, camp = _copy(trip, tmp_path, "cycle_nan")
    info = read_manifest(base / "store")["sessions"]["cycle_s1"]["cycles"]
    mid = info["phase_s"] + 2.5 * info["period_s"]  # the middle of cycle 2 (DAQ clock)
    daq = camp / "cycle_nan" / "daq.csv"
    lines = daq.read_text().splitlines()
    rows = [i for i, ln in enumerate(lines) if ln[:1].isdigit()
            and abs(float(ln.split(",")[0]) - mid) < 0.03]
    for i in rows:
        t, speed, _ = lines[i].split(",")
        lines[i] = f"{t},{speed},nan"
    daq.write_text("\n".join(lines) + "\n")
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    entry = read_manifest(store)["sessions"]["cycle_nan"]
    assert entry["rejected"].get("cycle with invalid samples") == 1
    assert any(n.startswith("cycle 2 ") and "non-finite" in n for n in entry["cycles"]["notes"])
    n_kept = entry["cycles"]["n_kept"]
    assert n_kept == info["n_kept"] - 1
    capsys.readouterr()
    assert main([*_verify(store, base / "opt", tmp_path / "v"), "--session", "cycle_nan"]) == 0
    out = capsys.readouterr().out
    assert f"{n_kept} of 5 cycles kept" in out and not re.search(r"\bnan\b", out.lower())
    record = json.loads((tmp_path / "v" / "verify.json").read_text())
    assert record["cycles_kept"] == record["means"]["n_cycles"] == n_kept
    assert all(v is not None and math.isfinite(v) for v in record["means"].values())


@pytest.mark.parametrize("edit, key", [
    (('speed_unit = "rpm"', 'speed_unit = "rad/s"'), "speed_unit"),
    (('torque_unit = "N m"', 'torque_unit = "kN m"'), "torque_unit"),
    (("n_cycles = 5", "n_cycles = 2.5"), "n_cycles"),
    ((r"e_elec_pred_j = \S+", "e_elec_pred_j = nan"), "e_elec_pred_j"),
])
def test_a_header_key_that_cannot_be_honoured_is_named(trip, tmp_path, capsys, edit, key):
    """Units other than the columns', a fractional cycle count, a NaN prediction: ingest
    exits 2 naming the profile and the key, the store as it was."""
    store, camp = _copy(trip, tmp_path, "cycle_key",
                        lambda t: re.sub(edit[0], edit[1], t, count=1))
    before = _stored(store)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"profile.csv: column '{key}'" in err and "Traceback" not in err
    assert "gear_ratio" not in err and "manifest" not in err
    assert _stored(store) == before


def test_verify_of_no_store_names_the_option(trip, tmp_path, capsys):
    base, _ = trip
    assert main(_verify(tmp_path / "nowhere", base / "opt", tmp_path / "v")) == 2
    err = capsys.readouterr().err
    assert "nowhere: option --store: not found" in err and "0 cycle-run" not in err


def test_export_options_are_named_as_given(trip, tmp_path, capsys):
    base, _ = trip
    for option in ("--cycles", "--rate-hz", "--standstill-s", "--ramp-s"):
        bad = "0"
        assert main(["cycle", "export", "--optimize", str(base / "opt"),
                     "--scenario", "elec-lim-7.0", option, bad,
                     "--out", str(tmp_path / "p.csv")]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"bench: error: {option} 0") or f"{option} 0" in err, err
        assert "--n-cycles" not in err
    assert not list(tmp_path.iterdir())


def test_a_nan_in_the_trajectories_is_named(trip, tmp_path, capsys):
    """A sweep whose trajectory holds a NaN: export exits 2 naming trajectories.parquet and
    the column, no traceback, nothing written."""
    opt = tmp_path / "opt"

    def nan_torque(traj) -> None:
        traj.loc[traj.index[3], "torque_nm"] = np.nan

    write_cycle_sweep(opt, edit=nan_torque)
    assert main(["cycle", "export", "--optimize", str(opt), "--scenario", "elec-lim-7.0",
                 "--out", str(tmp_path / "p.csv")]) == 2
    err = capsys.readouterr().err
    assert "trajectories.parquet: column 'torque_nm'" in err and "Traceback" not in err
    assert not (tmp_path / "p.csv").exists() and check_output_folder(opt)


def _retime(path: Path, col: int, fn) -> None:
    """Rewrite the rows of a log: ``fn(time, line)`` gives the new line or None to drop."""
    lines = path.read_text().splitlines()
    out = []
    for line in lines:
        if line[:1].isdigit():
            line = fn(float(line.split(",")[col]), line)
        if line is not None:
            out.append(line)
    path.write_text("\n".join(out) + "\n")


def test_a_log_cut_after_two_cycles_keeps_what_it_holds(trip, tmp_path, capsys):
    """The log stops half a cycle after cycle 1: cycle 1 is kept, the cycles after it
    rejected as not logged; no "different profile"."""
    base, _ = trip
    info = read_manifest(base / "store")["sessions"]["cycle_s1"]["cycles"]
    end = info["phase_s"] + 2.5 * info["period_s"]
    store, camp = _copy(trip, tmp_path, "cycle_cut")
    _retime(camp / "cycle_cut" / "daq.csv", 0, lambda t, ln: ln if t < end else None)
    _retime(camp / "cycle_cut" / "analyzer.csv", 1, lambda t, ln: ln if t < end else None)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    entry = read_manifest(store)["sessions"]["cycle_cut"]
    assert entry["cycles"]["n_kept"] == 1 and entry["rejected"]["cycle not logged"] == 3
    assert "different profile" not in capsys.readouterr().err


def test_a_clock_jump_is_named_in_the_log(trip, tmp_path, capsys):
    """The DAQ's clock jumps 2 s ahead in cycle 2: exit 2 naming daq.csv and the time of
    the jump, not "a different profile"; the store as it was."""
    base, _ = trip
    info = read_manifest(base / "store")["sessions"]["cycle_s1"]["cycles"]
    at = info["phase_s"] + 2.5 * info["period_s"]
    store, camp = _copy(trip, tmp_path, "cycle_jump")

    def jump(t: float, line: str) -> str:
        rest = line.split(",", 1)[1]
        return f"{t + 2.0:.3f},{rest}" if t >= at else line

    _retime(camp / "cycle_jump" / "daq.csv", 0, jump)
    before = _stored(store)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 2
    err = capsys.readouterr().err
    jumped = re.search(r"daq.csv: column 'time': .*the log's time jumps at ([0-9.]+) s", err)
    assert jumped and abs(float(jumped.group(1)) - at) < 0.1, err
    assert "different profile" not in err and _stored(store) == before


def test_a_run_whose_drive_stopped_early_is_not_blamed_on_the_profile(trip, tmp_path, capsys):
    """The drive stops half a cycle after cycle 1 and stays at standstill while the DAQ
    and the analyzer log on (a trip): the cycles before the stop are kept, those after it
    rejected, not "a different profile"."""
    base, _ = trip
    info = read_manifest(base / "store")["sessions"]["cycle_s1"]["cycles"]
    end = info["phase_s"] + 2.5 * info["period_s"]
    store, camp = _copy(trip, tmp_path, "cycle_stop")
    rng = np.random.default_rng(3)

    def stopped(t: float, line: str) -> str:
        return (line if t < end
                else f"{t:.3f},{rng.normal(0, 0.5):.2f},{rng.normal(0.15, 0.05):.3f}")

    def standby(t: float, line: str) -> str:
        if t < end:
            return line
        cells = line.split(",")
        return ",".join([*cells[:2], "400.0", "0.5", f"{rng.normal(195, 4):.0f}", "0.48"])

    _retime(camp / "cycle_stop" / "daq.csv", 0, stopped)
    _retime(camp / "cycle_stop" / "analyzer.csv", 1, standby)
    # was: exit 2, "the logged speed does not follow this profile (correlation 0.67 ...):
    # a different profile than the one named?"
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0
    out = capsys.readouterr()
    assert "different profile" not in out.err + out.out
    entry = read_manifest(store)["sessions"]["cycle_stop"]
    assert entry["cycles"]["n_kept"] == 1 and entry["rejected"]["cycle not logged"] == 3
    said = json.dumps(entry)
    assert re.search(r"the drive stopped at ([0-9.]+) s", said), said[:2000]
    at = float(re.search(r"the drive stopped at ([0-9.]+) s", said).group(1))
    assert abs(at - end) < 0.5 and "the run ended early" in said
