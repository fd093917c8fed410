"""Messages that named the cause wrongly or sent the user to an option that does not
exist: each now names the cause and an option that exists (the period scan's bounds,
the Weibull shape, the cycle commands' power model)."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from drivebench.cli import main
from energy.site import Weibull
from kernel.errors import InputError
from optimize.command import format_summary
from optimize.sweep_folder import UNCHECKED_HEAD


def _summary():
    """One converged elec-lim scenario the period scan held at no period."""
    return pd.DataFrame({
        "scenario": ["elec-lim-7.0"], "kind": ["elec-lim"], "status": ["Solve_Succeeded"],
        "success": [True], "iterations": [20], "total_wall_time_s": [1.0],
        "avg_p_elec_w": [-500.0],
        "avg_p_mech_w": [-600.0], "period_s": [5.1], "e_elec_j": [-2550.0],
        "peak_speed_rpm": [1000.0], "peak_torque_nm": [70.0], "p_elec_max_w": [900.0],
        "periods_scanned": [0], "result_check": ["passed"]})


def test_a_period_scan_that_held_nothing_names_the_bounds_not_the_option():
    # was: "--period-scan N looks for others" to a user who gave --period-scan 4, with
    # period bounds [4.6, 5.6] s that hold no period 15 % away from the optimum's 5.1 s
    text = format_summary(_summary(), 4, (4.6, 5.6))
    assert "--period-scan N looks" not in text
    assert "the period scan held none of their optima" in text
    assert "widen [bounds] period_min_s, period_max_s (now 4.6 to 5.6 s) for --period-scan 4" \
        in text
    assert "elec-lim: 1 converged wind speed" in text
    # without a scan asked, the option is the advice
    assert UNCHECKED_HEAD in format_summary(_summary())


@pytest.mark.parametrize("k", ["1e-9", "0.3", "12", "1e9", "nan", "inf"])
def test_an_implausible_weibull_shape_is_refused_before_any_solve(k, tmp_path, capsys):
    # was: 1e-9 an OverflowError traceback; 1e9 overflow warnings and AEP 0, exit 0
    code = main(["size", "--weibull-k", k, "--mean-speed", "5.5", "--out",
                 str(tmp_path / "s")])
    err = capsys.readouterr().err
    assert code == 2 and "--weibull-k" in err and "Traceback" not in err, err
    assert not (tmp_path / "s").exists()


def test_an_implausible_weibull_shape_in_an_aep_run(tmp_path, capsys):
    from energy_fixtures import write_optimize_folder

    from optimize.paper_model import paper_model

    opt = write_optimize_folder(tmp_path / "opt", paper_model())
    assert main(["aep", "--optimize", str(opt), "--weibull-k", "1e9", "--mean-speed", "5.5",
                 "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "--weibull-k 1e+09: implausible Weibull shape" in err and "Traceback" not in err
    assert main(["aep", "--optimize", str(opt), "--weibull-k", "2", "--mean-speed", "5.5",
                 "--out", str(tmp_path / "a")]) == 0


def test_the_weibull_site_refuses_shapes_whose_integrals_overflow():
    for k in (1e-9, 0.05, 200.0, 1e9):
        with pytest.raises(ValueError, match="integrals overflow"):
            Weibull.from_mean(k, 5.5)
        with pytest.raises(ValueError, match="integrals overflow"):
            Weibull(k, 6.0)
    assert Weibull.from_mean(2.0, 5.5).mean_m_s == pytest.approx(5.5)


def test_the_cycle_commands_name_options_they_have(tmp_path):
    # was: "(or give --model)", an option neither bench cycle export nor verify has
    from cycle.models import sweep_power_model
    from fitting.model_file import save_power_model
    from optimize.paper_model import paper_model

    folder = tmp_path / "opt"
    folder.mkdir()
    gone = tmp_path / "fit_out" / "power_model.json"
    manifest = {"drive_model": {"path": str(gone), "model_sha256": paper_model().sha256}}
    with pytest.raises(InputError) as err:
        sweep_power_model(folder, manifest)
    text = err.value.describe()
    assert "--model" not in text and f"a copy of it as {folder / 'power_model.json'}" in text
    gone.parent.mkdir()
    save_power_model(paper_model(), gone)
    data = json.loads(gone.read_text())
    for units in ("rpm", "si"):  # another drive's standby loss, the file itself valid
        data["coefficients"][units][0] *= 1.01
    gone.write_text(json.dumps(data))
    with pytest.raises(InputError) as err:
        sweep_power_model(folder, manifest)
    text = err.value.describe()
    assert "--model" not in text and "run bench optimize again with this model" in text
