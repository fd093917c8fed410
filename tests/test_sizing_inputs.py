"""``bench size`` checks each candidate as ``bench optimize`` checks the system's drive,
before any solve (energy/sizing.py ``Candidate.check``); ``--models`` files of one name are
told apart; a candidate that delivers nothing is never the best (energy/sizing.py,
energy/decision.py)."""

from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from drivebench.cli import main
from energy.candidates import build_candidates
from energy.site import Weibull
from energy.sizing import candidate_table, idle_lines, scaled_candidates, size_extending
from fitting.model_file import save_power_model
from kernel.errors import InputError
from optimize.model.drivetrain import carry_power_model
from optimize.paper_model import paper_model
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

SITE = ["--rayleigh-mean", "5.5", "--no-progress", "--workers", "1"]


def _model_file(path, torque_ratio):
    """The paper drive carried to ``torque_ratio`` times its torque rating (a drive of the
    same design, consistent in itself), as a power-model file."""
    base = paper_model()
    drive = dataclasses.replace(base.drive, max_torque_nm=78.0 * torque_ratio,
                                nominal_power_w=base.nominal_power_w * torque_ratio)
    model = carry_power_model(base, 1.0, torque_ratio, drive=drive)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_power_model(model, path)
    return path


def test_a_candidate_bench_optimize_refuses_is_refused_before_any_solve(tmp_path, capsys):
    # the case: a 1.46 N m drive (an ODrive's) was flown for 48 s; bench optimize
    # refuses it as the system's drive at once
    tiny = _model_file(tmp_path / "odrive.json", 1.46 / 78.0)
    argv = ["size", "--scales", "1", "--models", str(tiny), "--wind-grid", "7,8",
            "--out", str(tmp_path / "s"), *SITE]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"candidate odrive (--models {tiny}): [drive] max_torque_nm: 1.46 N m" in err, err
    assert "less than the kite's weight" in err and not (tmp_path / "s").exists()
    assert main(["optimize", "--drive-model", str(tiny), "--wind-grid", "7",
                 "--out", str(tmp_path / "o")]) == 2  # as bench optimize refuses it


def test_a_scale_too_small_to_hold_the_kite_is_refused_naming_the_option(tmp_path, capsys):
    # was: --scales 1e-6 solved 52 s to Infeasible_Problem_Detected
    assert main(["size", "--scales", "1e-6,1", "--wind-grid", "7,8",
                 "--out", str(tmp_path / "s"), *SITE]) == 2
    err = capsys.readouterr().err
    assert "candidate x1e-06 (--scales 1e-06): [drive] max_torque_nm: 7.8e-05 N m" in err, err


def test_a_scale_beyond_the_edge_that_cannot_fly_ends_the_extension(tmp_path):
    # --extend halves the smallest scale while it is the best: a candidate refused there
    # ends the extension with a note instead of failing the sizing after its solves
    system = load_system()
    drive, _ = drive_in_force(system, drive_model=paper_model())

    def make(scales):
        made, _ = build_candidates(drive, scales)
        for c in made:
            c.check(system)
        return made

    def run(cands):
        rows = [{"candidate": c.name, "scale": c.scale, "rated_torque_nm": c.rated_torque_nm,
                 "aep_elec_mwh": 1.0 / c.scale} for c in cands]  # the smallest is the best
        table = pd.DataFrame(rows)
        best = table.loc[table["aep_elec_mwh"].idxmax(), "candidate"]
        return dataclasses.make_dataclass("R", ["table", "best", "n_solved", "n_cached",
                                                "wall_time_s"])(table, best, 0, 0, 0.0)

    refused = []
    res, edge, added = size_extending(make, (0.5, 1.0), 3, run, refused)
    # 0.0625 x 78 N m on the 0.1 m drum holds 49 N, less than the kite's 73.6 N
    assert edge == "smallest" and added == [0.25, 0.125] and res.best == "x0.125"
    assert len(refused) == 1 and refused[0].startswith("scale x0.0625 beyond the edge not sized")
    assert "candidate x0.0625 (--scales 0.0625)" in refused[0]
    with pytest.raises(InputError, match="candidate x0.001"):  # asked for: refused
        size_extending(make, (0.001, 1.0), 3, run, refused)


def test_models_of_one_file_name_are_told_apart_and_one_file_twice_is_refused(tmp_path):
    # was: two --models files named power_model.json ran every solve, then a ValueError
    a = _model_file(tmp_path / "a" / "power_model.json", 1.0)
    b = _model_file(tmp_path / "b" / "power_model.json", 2.0)
    x2 = _model_file(tmp_path / "x2.json", 2.0)  # the name of the scale x2
    own = _model_file(tmp_path / "own.json", 1.5)
    drive, _ = drive_in_force(load_system(), drive_model=paper_model())
    cands, _ = build_candidates(drive, (1.0, 2.0), (a, b, x2, own))
    assert [c.name for c in cands] == ["x1", "x2", str(a), str(b), str(x2), "own"]
    with pytest.raises(InputError, match="given twice to --models"):
        build_candidates(drive, (1.0,), (own, tmp_path / "." / "own.json"))


def test_a_candidate_that_delivers_nothing_is_never_the_best():
    # was: --scales 1e6 gave every candidate an AEP of 0 and named one "best"
    rating = drive_in_force(load_system(), drive_model=paper_model())[0].rating_part()
    cands = scaled_candidates(rating.with_losses(paper_model()), (1e6, 2e6))
    recs = [{"candidate": c.name, "wind_speed_m_s": w, "success": True,
             "avg_p_elec_w": 2.9e8 * c.scale / 1e6, "rms_torque_nm": 1.0}
            for c in cands for w in (7.0, 8.0)]
    table, best, chosen = candidate_table(cands, recs, Weibull(2.0, 6.2))
    assert (table["aep_elec_mwh"] == 0).all() and (best, chosen) == (None, None)
    lines = idle_lines(table, recs)
    assert len(lines) == 2 and lines[0].startswith("x1e+06 delivers no energy")
    assert "2.9e+08 to 2.9e+08 W" in lines[0]
