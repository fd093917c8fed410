"""Key results carry the bench round trip's verdict, in words that say which way the power
model misses (issue 42: the +17.7 % on negative energies was only in section 6)."""

from __future__ import annotations

import pandas as pd

from cycle.verify_folder import write_verify_folder
from kernel.provenance import Provenance
from reports.render import build_context, render
from reports.verification_section import prediction_words, round_trip_verdict

#: a verify.json's record: the model's energy per cycle -823 J against -1000 J measured
#: (generated), the optimizer's -1050 J
RECORD = {"session": "cycle_01", "scenario": "elec-lim-7.0", "cycles_kept": 8,
          "cycles_in_profile": 10, "verdict": "The steady-state power model ...",
          "means": {"e_elec_j": -1000.0, "e_elec_model_j": -823.0, "model_error": 0.177,
                    "model_error_band": 0.02, "e_elec_optimizer_j": -1050.0,
                    "optimizer_error": -0.05, "band_elec_j": 5.0}}


def test_prediction_words_say_the_direction_on_generated_and_drawn_energy():
    # (E_pred - E_meas) / |E_meas|: +17.7 % on -1000 J is -823 J, less generated
    assert prediction_words(0.177, -1000.0) == "17.7 % less energy generated than measured"
    assert prediction_words(-0.05, -1000.0) == "5.0 % more energy generated than measured"
    assert prediction_words(0.1, 500.0) == "10.0 % more energy drawn than measured"
    assert prediction_words(None, 500.0) == "n/a"


def test_key_results_carry_the_round_trip_verdict(tmp_path):
    # issue 49: no PASS / FAIL against a stated tolerance, and signs that read both ways
    text = round_trip_verdict(RECORD)
    assert text.startswith("FAIL against +-5 %: the power model at the measured speed and "
                           "torque predicts 823 J generated per cycle against 1000 J measured "
                           "(17.7 % less energy generated than measured")
    assert "the optimizer promised 1050 J generated (5.0 % more energy generated" in text
    assert round_trip_verdict({**RECORD, "means": {**RECORD["means"], "model_error": 0.03,
                                                   "e_elec_model_j": -970.0}}).startswith(
        "PASS against +-5 %")
    cycles = pd.DataFrame({"cycle_id": [1], "e_elec_j": [-1000.0], "u_elec_j": [2.0],
                           "e_elec_model_j": [-823.0], "e_elec_optimizer_j": [-1050.0],
                           "e_mech_j": [-1100.0], "u_mech_j": [2.0]})
    one = pd.DataFrame({"time_s": [0.0, 1.0], "p_elec_measured_w": [-1.0, -2.0],
                        "p_elec_model_w": [-1.0, -2.0], "p_elec_optimizer_w": [-1.0, -2.0],
                        "p_mech_measured_w": [-1.0, -2.0]})
    verify = write_verify_folder(tmp_path / "verify", Provenance.start(["test"]), RECORD,
                                 cycles, one)
    none = tmp_path / "none"
    ctx = build_context(none, none, none, ["bench", "report"], none, none, verify)
    assert ("bench round trip (cycle verify)", text) in ctx["headline"]
    html = render(ctx)
    summary = html[html.index('id="summary"'):html.index("</section>", html.index('id="summary"'))]
    assert "17.7 % less energy generated than measured" in summary
    # no verification: no row
    ctx = build_context(none, none, none, ["bench", "report"], none, none, none)
    assert all(k != "bench round trip (cycle verify)" for k, _ in ctx["headline"])


def test_verify_power_plot_says_which_cycle_of_the_run_its_time_counts_from():
    # issue 42: the x label read "time in cycle 5 [s]"
    from reports.verification_section import power_figure

    one = pd.DataFrame({"time_s": [0.0, 1.0], "p_elec_measured_w": [-1.0, -2.0],
                        "p_elec_model_w": [-1.0, -2.0], "p_elec_optimizer_w": [-1.0, -2.0],
                        "p_mech_measured_w": [-1.0, -2.0]})
    svg = str(power_figure(one, 5))
    assert "time from the start of cycle 5 of the run [s]" in svg.replace("\n", " ")
