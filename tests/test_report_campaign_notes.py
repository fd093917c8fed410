"""The campaign section says what the store holds (issue 42): rejected cycles of a cycle
run are not counted as steady-state windows, and operating points beyond the drive's
stated rating are said, with how far."""

from __future__ import annotations

import pandas as pd

from reports.campaign_section import beyond_rating, rejected_reasons

MANIFEST = {"sessions": {
    "motor_01": {"kind": "timeseries", "rejected": {"unsteady": 5},
                 "drive": {"max_speed_rpm": 1500.0, "max_torque_nm": 78.0}},
    "cycle_01": {"kind": "cycle_run", "rejected": {"clipped": 2},
                 "drive": {"max_speed_rpm": 1500.0, "max_torque_nm": 78.0}}}}


def test_rejected_cycles_are_not_counted_as_windows():
    rejected = pd.DataFrame({"session_id": ["motor_01"] * 5 + ["cycle_01"] * 2,
                             "reason": ["unsteady"] * 5 + ["clipped"] * 2,
                             "t_start_s": 0.0, "t_end_s": 1.0})
    expected = [{"reason": "unsteady", "what": "window", "count": 5},
                {"reason": "clipped", "what": "cycle", "count": 2}]
    assert rejected_reasons(rejected, MANIFEST) == expected
    assert rejected_reasons(None, MANIFEST) == expected  # from the manifest's counts


def test_points_beyond_the_stated_rating_are_said():
    points = pd.DataFrame({"session_id": ["motor_01"] * 4,
                           "speed_rpm": [-3000.0, -1000.0, 1500.0, 2000.0],
                           "torque_nm": [10.0, 20.0, 78.5, 30.0]})
    # 1500 rpm is on the limit; 78.5 N m within 1 % of the 78 N m one
    (line,) = beyond_rating(points, MANIFEST)
    assert line.startswith("2 of 4 operating points lie more than 1 % beyond the drive's stated "
                           "max_speed_rpm (1500 rpm at the drum, session motor_01): up to "
                           "3000 rpm, 2.0 x the rating")
    assert beyond_rating(points.iloc[1:3], MANIFEST) == []
