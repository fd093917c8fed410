"""Output files of bench optimize: schema, units metadata, failed rows, atomic writes."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import pandas as pd
import pyarrow.parquet as pq
import pytest
from system_fixtures import system_for

from kernel.errors import InputError
from kernel.files import write_parquet
from kernel.units import unit_of
from optimize.model import kite_model as km
from optimize.paper_model import paper_model
from optimize.problem.ocp import model_parts
from optimize.problem.part import FRAME_COLUMNS, trajectory_columns
from optimize.problem.scenario import Scenario
from optimize.service.outcome import Attempt, ScenarioOutcome
from optimize.sweep.outputs import summary_frame, trajectories_frame
from optimize.sweep_folder import SUMMARY_COLUMNS, field_units, read_summary


@dataclass(frozen=True)
class FakeResult:
    """Just the fields the summary reads; the trajectory is hand-made below."""

    period_s: float
    avg_p_elec_w: float
    avg_p_mech_w: float
    periodicity_error: float
    max_violation: float
    trajectory: pd.DataFrame
    figures: dict = field(default_factory=dict)


def hand_trajectory() -> pd.DataFrame:
    # 4 points with known extremes: reel-out at -1200 rpm, reel-in at +900 rpm
    return pd.DataFrame(
        {
            "time_s": [1.0, 2.0, 3.0, 4.0],
            "l_m": [150.0, 180.0, 210.0, 160.0],
            "ddl_m_s2": [3.0, -4.5, 1.0, 0.0],
            "speed_rpm": [-1200.0, -800.0, 900.0, 300.0],
            "torque_nm": [60.0, 78.0, 10.0, 20.0],
            "p_elec_w": [-6000.0, -5000.0, 1500.0, 900.0],
            "p_mech_w": [-7500.0, -6500.0, 900.0, 600.0],
            "altitude_m": [80.0, 95.0, 120.0, 70.0],
            "weight": [0.25, 0.25, 0.25, 0.25],
        }
    )


def outcomes() -> list[ScenarioOutcome]:
    ok = ScenarioOutcome(
        Scenario.of_kind("elec-lim", 5.5),
        0,
        (Attempt("elec-lim-7.0", "Solve_Succeeded", True, 14, 2.5),),
        FakeResult(6.0, -137.8, -900.0, 1e-9, 2e-8, hand_trajectory()),
    )
    failed = ScenarioOutcome(
        Scenario.of_kind("mech-free", 10.0),
        1,
        (
            Attempt("mech-free-8.5", "Infeasible_Problem_Detected", False, 40, 6.0),
            Attempt(None, "Maximum_Iterations_Exceeded", False, 1000, 90.0),
        ),
        None,
    )
    return [ok, failed]


def test_summary_metrics_from_a_hand_made_cycle():
    s = summary_frame(outcomes()).set_index("scenario")
    row = s.loc["elec-lim-5.5"]
    # energy per cycle = average power x period: -137.8 W x 6 s = -826.8 J (about Fig. 3)
    assert row["e_elec_j"] == pytest.approx(-826.8, rel=1e-12)
    assert row["e_mech_j"] == pytest.approx(-5400.0, rel=1e-12)
    assert row["peak_speed_rpm"] == 1200.0 and row["peak_torque_nm"] == 78.0
    assert row["peak_reel_acceleration_m_s2"] == 4.5
    assert (row["p_elec_max_w"], row["p_elec_min_w"]) == (1500.0, -6000.0)
    assert (row["tether_length_min_m"], row["tether_length_max_m"]) == (150.0, 210.0)
    assert (row["altitude_min_m"], row["altitude_max_m"]) == (70.0, 120.0)
    assert row["warm_source"] == "elec-lim-7.0" and row["objective"] == "electrical"
    bad = s.loc["mech-free-10.0"]
    # a failed scenario is a row with its status, attempts, time, and NaN metrics
    assert not bad["success"] and bad["status"] == "Maximum_Iterations_Exceeded"
    assert bad["attempts"] == 2 and bad["total_wall_time_s"] == 96.0
    assert bad["warm_source"] == "cold start" and not bad["drive_limits"]
    metrics = list(SUMMARY_COLUMNS)[list(SUMMARY_COLUMNS).index("period_s") :]
    assert all(math.isnan(bad[c]) for c in metrics)


def test_summary_marks_cycle_points_outside_the_validity_domain():
    # A motor-only model (domain: 50..1500 rpm x 1..78 N m, motor side): the two
    # reel-out points (-1200 rpm, 60 N m) and (-800 rpm, 78 N m) lie outside, half the
    # cycle time (equal weights). The farthest is -1200 rpm: nearest domain point
    # (50, 60), distance 1250 / 1500 in units of the drive rating.
    box = [[50.0, 1.0], [1500.0, 1.0], [1500.0, 78.0], [50.0, 78.0]]
    s = summary_frame(outcomes(), {"motor": box}, (1500.0, 78.0)).set_index("scenario")
    row = s.loc["elec-lim-5.5"]
    assert row["outside_domain_time_frac"] == pytest.approx(0.5, rel=1e-12)
    assert (row["outside_worst_speed_rpm"], row["outside_worst_torque_nm"]) == (-1200.0, 60.0)
    assert row["outside_worst_distance"] == pytest.approx(1250 / 1500, rel=1e-12)
    # the drive's losses P_elec - P_mech: 1500, 1500, 600, 300 W; the first two outside
    assert row["outside_domain_loss_frac"] == pytest.approx(3000 / 3900, rel=1e-12)
    # a two-quadrant domain holding the whole cycle: nothing outside
    gen = [[-1500.0, 1.0], [-40.0, 1.0], [-40.0, 78.0], [-1500.0, 78.0]]
    inside = summary_frame(outcomes(), {"motor": box, "generator": gen}, (1500.0, 78.0))
    assert inside.set_index("scenario").loc["elec-lim-5.5", "outside_domain_time_frac"] == 0.0
    from optimize.command import format_summary
    assert ("50.0 % of the cycle time, 76.9 % of its drive losses outside"
            in format_summary(s.reset_index()))


def test_summary_round_trip_keeps_values_and_units(tmp_path):
    frame = summary_frame(outcomes())
    path = write_parquet(tmp_path / "summary.parquet", frame, descriptions=SUMMARY_COLUMNS)
    back = read_summary(path)
    pd.testing.assert_frame_equal(back, frame)
    units = field_units(path)
    assert units["avg_p_elec_w"] == "W" and units["peak_torque_nm"] == "N m"
    assert units["wind_speed_m_s"] == "m/s" and units["period_s"] == "s"
    assert units["e_elec_j"] == "J" and units["peak_speed_rpm"] == "rpm"
    meta = pq.read_schema(path).field("status").metadata
    assert meta[b"description"].startswith(b"IPOPT return status")
    assert not list(tmp_path.glob(".*.tmp"))  # temp file moved into place


def test_the_parts_figures_fill_the_summary_and_a_new_one_follows_its_columns():
    """A result's part figures (``OcpResult.figures``) land in the schema's columns (the
    winding's) or, a figure the schema does not name, after them; NaN where it failed."""
    ok, failed = outcomes()
    figures = {"peak_winding_temperature_c": 38.5, "thermal_margin_k": 1.5,
               "filter_peak_m_s": 2.25}
    ok = replace(ok, result=replace(ok.result, figures=figures))
    frame = summary_frame([ok, failed])
    assert list(frame.columns) == [*SUMMARY_COLUMNS, "filter_peak_m_s"]
    rows = frame.set_index("scenario")
    for name, value in figures.items():
        assert rows.loc["elec-lim-5.5", name] == value
        assert math.isnan(rows.loc["mech-free-10.0", name])
    plain = summary_frame(outcomes())  # no thermal part: the schema's columns, NaN
    assert list(plain.columns) == list(SUMMARY_COLUMNS)
    assert plain["thermal_margin_k"].isna().all()


def test_trajectories_hold_only_converged_scenarios(tmp_path):
    traj = trajectories_frame(outcomes(), tuple(hand_trajectory()))
    assert list(traj["scenario"].unique()) == ["elec-lim-5.5"] and len(traj) == 4
    path = write_parquet(tmp_path / "trajectories.parquet", traj)
    assert field_units(path)["torque_nm"] == "N m"
    assert pd.read_parquet(path)["p_elec_w"].sum() == -8600.0


def test_the_paper_parts_give_each_trajectory_column_its_unit():
    # the units each output column is meant to have, written out here as the truth
    outputs = {
        "time_s": "s", "interval": "", "weight": "", "speed_rpm": "rpm", "torque_nm": "N m",
        "tether_torque_nm": "N m", "tension_n": "N", "p_mech_w": "W", "p_elec_w": "W",
        "altitude_m": "m", "airspeed_m_s": "m/s", "alpha_deg": "deg", "beta_deg": "deg",
        "wind_m_s": "m/s", "line_angle_deg": "deg", "c_m2": "m^2", "cdot_m2_s": "m^2/s",
    }
    columns = trajectory_columns(model_parts(km.kite_dae(), paper_model(), system=system_for()))
    variables = (*km.STATES.names, *km.CONTROLS.names, *km.ALGEBRAIC.names)
    assert list(columns) == [*outputs][:3] + [*variables] + [
        c for c in columns if c in outputs and c not in FRAME_COLUMNS]
    assert {c: u for c, u in columns.items() if c not in variables} == outputs
    want = {
        "r_x_m": "m",
        "v_y_m_s": "m/s",
        "dcm_21": "1",
        "omega_z_rad_s": "rad/s",
        "ddl_m_s2": "m/s^2",
        "dddl_m_s3": "m/s^3",
        "daileron_rad_s": "rad/s",
        "domega_x_rad_s2": "rad/s^2",
        "nu_n_per_m": "N/m",
        "aileron_rad": "rad",
    }
    for name in variables:
        assert columns[name] == unit_of(name) != "", name
    for name, unit in want.items():
        assert unit_of(name) == unit


def test_read_summary_names_file_and_column(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_summary(tmp_path / "nope.parquet")
    path = write_parquet(tmp_path / "s.parquet", pd.DataFrame({"scenario": ["x"]}))
    with pytest.raises(InputError) as err:
        read_summary(path)
    assert "s.parquet" in str(err.value) and "column 'kind'" in str(err.value)
