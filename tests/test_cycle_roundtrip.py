"""The cycle round trip on the synthetic bench: export -> ``bench synth --cycle-run`` ->
``bench ingest`` -> ``bench cycle verify``, against the synthetic truth (the true energy
of every cycle, ``cycle_truth.json``), for a few seeds; and the hostile logs (half the
cycles missing, the wrong gear ratio, the torque's sign flipped, another profile than
the one named) refused or flagged, nothing stored lost."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest

from bench.cycle_profile import BenchFrame, read_profile, window_integral
from bench.ingest.pipeline import ingest
from bench.synth.cycle_run import run_signals
from bench.synth.cycle_session import CycleRunSpec, campaign_loss_model, write_cycle_run
from cycle.export import ExportOptions, export_cycle
from cycle.verify import K
from cycle.verify_command import verify_cycles
from drivebench.cli import main
from kernel.errors import InputError
from tests.cycle_fixtures import copy_session, write_cycle_sweep

ROOT = Path(__file__).resolve().parent.parent
TRUTH = ROOT / "raw_measurements" / "truth.json"
SEEDS = (1, 2, 3)
#: the bench's frame: the torque flange and encoder on the motor side of the 1:3 gearbox
FRAME = BenchFrame("motor", 3.0, 1, 1)


def _quiet(line: str) -> None:
    pass


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    base = tmp_path_factory.mktemp("roundtrip")
    model = write_cycle_sweep(base / "opt")
    for scenario, name in (("elec-lim-7.0", "profile.csv"), ("elec-lim-5.5", "other.csv")):
        export_cycle(base / "opt", scenario, base / name, ExportOptions(n_cycles=5, frame=FRAME))
    camp = base / "campaign"
    camp.mkdir()
    shutil.copy(ROOT / "raw_measurements" / "drive.toml", camp)
    truths = {}
    for seed in SEEDS:
        run = dataclasses.replace(CycleRunSpec(), session_id=f"cycle_s{seed}", seed=seed)
        truths[run.session_id] = write_cycle_run(camp, base / "profile.csv", run,
                                                 truth_path=TRUTH)
    ingest([camp], base / "store", progress=False, notify=_quiet)
    return base, truths, model


def test_measured_energy_covers_the_truth(rig):
    """Every kept cycle's measured electrical energy is within K = 2 standard
    uncertainties of its true energy, and the mean's 95 % band covers the true mean, for
    each seed; the mechanical energy likewise."""
    base, truths, _ = rig
    for sid, truth in truths.items():
        done = verify_cycles(base / "store", base / "opt", base / f"verify_{sid}", session=sid)
        t = done.cycles
        assert len(t) >= 3
        true_e = np.asarray(truth["cycles"]["e_elec_j"])[t["cycle_id"]]
        true_m = np.asarray(truth["cycles"]["e_mech_j"])[t["cycle_id"]]
        assert np.all(np.abs(t["e_elec_j"] - true_e) <= K * t["u_elec_j"]), sid
        assert np.all(np.abs(t["e_mech_j"] - true_m) <= K * t["u_mech_j"]), sid
        m = done.record["means"]
        assert abs(m["e_elec_j"] - true_e.mean()) <= m["band_elec_j"], sid
        assert abs(m["e_mech_j"] - true_m.mean()) <= m["band_mech_j"], sid
        # the band is the analyzer's limits of error, not a blanket: about 1 % here
        assert m["band_elec_j"] < 0.02 * abs(m["e_elec_j"])


def test_model_prediction_is_the_model_on_the_true_run(rig):
    """The power model's energy at the measured speed and torque equals the model
    integrated over the true signals within 0.5 % (the instruments' noise, resolution and
    calibration errors between them)."""
    base, truths, model = rig
    sid = next(iter(truths))
    done = verify_cycles(base / "store", base / "opt", base / "verify_model", session=sid)
    profile = read_profile(base / "profile.csv")
    sig = run_signals(profile, campaign_loss_model(TRUTH), CycleRunSpec().bench)
    p = model.p_elec_w(sig.speed_rpm, sig.torque_nm)
    for r in done.cycles.itertuples():
        e = window_integral(sig.time_s, p, r.t_start_s, r.t_end_s)
        assert r.e_elec_model_j == pytest.approx(e, rel=5e-3)


def test_verify_command_line(rig, capsys):
    base, truths, _ = rig
    sid = next(iter(truths))
    rc = main(["cycle", "verify", "--store", str(base / "store"), "--optimize",
               str(base / "opt"), "--session", sid, "--out", str(base / "verify_cli")])
    out = capsys.readouterr().out
    assert rc == 0 and "of 5 cycles kept" in out and "electrical energy per cycle" in out
    assert "against +-5 % (the steady map's accuracy on dynamic cycles" in out
    assert (base / "verify_cli" / "verify.json").is_file()
    # several cycle runs in the store and none named: refused, naming them
    assert main(["cycle", "verify", "--store", str(base / "store"), "--optimize",
                 str(base / "opt"), "--out", str(base / "verify_none")]) == 2
    assert "cycle_s1, cycle_s2, cycle_s3" in capsys.readouterr().err


def _hostile(rig, tmp_path, name: str):
    """A copy of the rig's store and a campaign holding one copy of a good session."""
    return copy_session(rig[0], tmp_path, name)


def _refused(store: Path, camp: Path, match: str) -> None:
    before = (store / "manifest.json").read_bytes()
    with pytest.raises(InputError, match=match):
        ingest([camp], store, progress=False, notify=_quiet)
    assert (store / "manifest.json").read_bytes() == before


def test_half_the_cycles_missing_is_flagged(rig, tmp_path):
    """The log stops in the middle of the run: the cycles it does not hold are rejected
    as not logged, the others kept, the stored sessions kept."""
    store, camp = _hostile(rig, tmp_path, "cycle_half")
    for name, col in (("daq.csv", 0), ("analyzer.csv", 1)):
        path = camp / "cycle_half" / name
        lines = path.read_text().splitlines()
        head = [i for i, line in enumerate(lines) if line[:1].isdigit()][0]
        keep = [line for line in lines[head:] if float(line.split(",")[col]) < 36.0]
        path.write_text("\n".join(lines[:head] + keep) + "\n")
    done = ingest([camp], store, progress=False, notify=_quiet)
    entry = done.manifest["sessions"]["cycle_half"]
    assert entry["rejected"]["cycle not logged"] >= 2 and entry["cycles"]["n_kept"] >= 1
    assert any("the log (daq.csv) holds" in n for n in entry["cycles"]["notes"])
    assert {"cycle_s1", "cycle_s2", "cycle_s3"} <= set(done.manifest["sessions"])


@pytest.mark.parametrize("edit, match", [
    (('gear_ratio = 3.0', 'gear_ratio = 2.0'), "check gear_ratio and measured_side"),
    (('torque_sign = 1', 'torque_sign = -1'), "torque_sign"),
])
def test_wrong_frame_is_refused(rig, tmp_path, edit, match):
    """session.toml's frame does not match the log: refused naming the key, the store as
    it was."""
    store, camp = _hostile(rig, tmp_path, "cycle_bad")
    toml = camp / "cycle_bad" / "session.toml"
    assert edit[0] in toml.read_text()
    toml.write_text(toml.read_text().replace(edit[0], edit[1]))
    _refused(store, camp, match)


def test_another_profile_than_named_is_refused(rig, tmp_path):
    base, _, _ = rig
    store, camp = _hostile(rig, tmp_path, "cycle_other")
    shutil.copy(base / "other.csv", camp / "cycle_other" / "profile.csv")
    _refused(store, camp, "a different profile than the one named")


def test_report_shows_the_verification(rig):
    """``bench report --verify``: the section holds the verdict, the table and both
    figures; without the folder it says the stage was not run."""
    from reports.render import build_context, render

    base, truths, _ = rig
    sid = next(iter(truths))
    done = verify_cycles(base / "store", base / "opt", base / "verify_report", session=sid)
    none = base / "none"
    html = render(build_context(none, none, none, ["bench", "report"], none, none,
                                base / "verify_report"))
    section = html[html.index('<section id="verification">'):]
    section = section[:section.index("</section>")]
    import html as markup

    assert done.verdict.split(":")[0] in markup.unescape(section) and "cycles kept" in section
    assert section.count("<svg") == 2
    html = render(build_context(none, none, none, ["bench", "report"], none, none, none))
    assert "Not run: bench cycle verify" in html


def test_verdict_in_words():
    """PASS, FAIL or INCONCLUSIVE against 5 % first; every energy said as generated; the
    drift when resolved; the map's residual std held over a cycle; the limits of error a
    session left out."""
    from cycle.verify_command import verdict

    means = {"model_error": 0.02, "model_error_band": 0.01, "e_elec_optimizer_j": -1000.0,
             "e_elec_model_j": -980.0,
             "optimizer_error": 0.03, "e_elec_j": -1000.0, "optimizer_error_band": 0.01,
             "n_cycles": 8}
    still = {"slope_j_per_cycle": 0.1, "slope_u_j_per_cycle": 0.2, "slope_per_cycle": 1e-4}
    text = verdict(means, still, [], (120.0, 5.0))
    assert text.startswith("PASS against +-5 %") and "No drift" in text
    assert "predicts 980 J generated per cycle against 1000 J measured, 2.0 % less" in text
    assert "600 J, 60.0 %" in text
    text = verdict({**means, "model_error": -0.2, "e_elec_model_j": -1200.0},
                   {**still, "slope_j_per_cycle": -3.0}, ["power_accuracy_range"])
    assert text.startswith("FAIL against +-5 %") and "drifts by -3.0 J" in text
    assert "1200 J generated per cycle against 1000 J measured, 20.0 % more" in text
    assert "does not state power_accuracy_range" in text and "residual" not in text
    assert verdict({**means, "model_error": 0.045}, still, []).startswith("INCONCLUSIVE")
    # a cycle that draws power on balance: every energy said as drawn
    drawn = verdict({**means, "e_elec_j": 250.0, "e_elec_model_j": 260.0,
                     "e_elec_optimizer_j": 1050.0, "model_error": 0.04, "optimizer_error": 3.2},
                    still, [])
    assert "predicts 260 J drawn per cycle against 250 J measured, 4.0 % more" in drawn
    assert "promised 1050 J drawn" in drawn
