"""The adaptive wind grid on a power curve with a cut-in kink and a limit plateau."""

from __future__ import annotations

import numpy as np
import pytest

from energy.adaptive import refine_grid
from energy.aep import aep_mwh
from energy.site import Weibull


def _curve(v: float) -> float:
    # consumes below 4.3 m/s, grows with the cube, capped at 2 kW by a drive limit at ~8.2 m/s
    return -min(2000.0, 35.0 * (v**3 - 4.3**3) / 4.3) if v > 4.3 else 60.0 * (4.3 - v)


def test_refined_grid_is_within_1_percent_of_a_quarter_metre_grid_with_fewer_points():
    site = Weibull.from_mean(2.0, 5.5)
    fine = np.arange(4.0, 10.0 + 1e-9, 0.25)
    reference = aep_mwh(fine, np.array([_curve(v) for v in fine]), site)
    coarse = (4.0, 5.5, 7.0, 8.5, 10.0)
    coarse_aep = aep_mwh(np.array(coarse), np.array([_curve(v) for v in coarse]), site)
    calls = []

    def power(v):
        calls.append(v)
        return _curve(v)

    r = refine_grid(power, coarse, site)
    assert abs(coarse_aep / reference - 1) > 0.01  # the coarse grid alone misses by > 1 %
    assert r.aep_mwh == pytest.approx(reference, rel=0.01)
    assert len(calls) < len(fine)
    assert len(set(calls)) == len(calls)  # no speed solved twice


def test_failed_solves_are_left_out_and_reported():
    site = Weibull.from_mean(2.0, 5.5)
    r = refine_grid(lambda v: None if abs(v - 4.75) < 1e-9 else _curve(v),
                    (4.0, 5.5, 7.0, 8.5, 10.0), site)
    assert 4.75 in r.failed and 4.75 not in r.wind_speed_m_s
