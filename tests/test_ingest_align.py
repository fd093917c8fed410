"""Clock alignment against a known synthetic offset and drift; the as-of join by hand."""

from __future__ import annotations

import numpy as np
import pytest

from bench.ingest.align import asof_nearest, estimate_clock


def _staircase(t, rng, hold=7.0):
    """A random power staircase [W] with 0.3 s first-order transitions."""
    levels = rng.uniform(-8000, 8000, int(t[-1] / hold) + 2)
    k = (t // hold).astype(int)
    frac = (t - k * hold) / 0.3
    prev = levels[np.maximum(k - 1, 0)]
    return levels[k] + (prev - levels[k]) * np.exp(-frac)


@pytest.mark.parametrize(("offset", "drift_ppm"), [(2.37, 60.0), (-1.9, -45.0), (0.4, 0.0)])
def test_recovers_offset_and_drift(offset, drift_ppm):
    rng = np.random.default_rng(11)
    dt = 0.1
    grid = np.arange(0.05, 3000.0, dt)  # 50 min session on the DAQ clock
    p_mech = _staircase(grid, rng) + rng.normal(0, 20, grid.size)
    ta = np.arange(0.0, 2990.0, 0.1)  # analyzer clock, 10 Hz
    td = offset + (1 + drift_ppm * 1e-6) * ta
    p_elec = 1.08 * np.interp(td, grid, p_mech) + 300 + rng.normal(0, 5, ta.size)
    prior = offset + 1.6  # the header clocks disagree by 1.6 s
    clock = estimate_clock(grid, p_mech, ta, p_elec, prior)
    # 20 ms = a fifth of the 0.1 s analyzer interval: the sub-sample refinement lands
    # within ~8 ms here (noise and the re-interpolation bias), far below one sample
    assert clock.offset_s == pytest.approx(offset, abs=0.02)
    # drift from two half-session offsets 1500 s apart, each good to ~5 ms -> ~5 ppm
    assert clock.drift_ppm == pytest.approx(drift_ppm, abs=8.0)
    assert clock.correlation > 0.5
    assert clock.prior_offset_s == prior
    # the model maps analyzer times onto the DAQ clock
    np.testing.assert_allclose(clock.to_daq(ta[[0, -1]]), td[[0, -1]], atol=0.02)


def test_flipped_power_gives_negative_correlation():
    rng = np.random.default_rng(2)
    grid = np.arange(0.05, 600.0, 0.1)
    p = _staircase(grid, rng)
    ta = np.arange(0.0, 590.0, 0.1)
    clock = estimate_clock(grid, -p, ta, np.interp(ta + 1.0, grid, p), 0.0)
    assert clock.offset_s == pytest.approx(1.0, abs=0.01)
    assert clock.correlation < -0.5


def test_asof_nearest_by_hand():
    t_ref = np.array([0.0, 0.1, 0.2, 0.3])
    vals = np.array([10.0, 11.0, np.nan, 13.0])
    q = np.array([-0.2, -0.04, 0.04, 0.06, 0.19, 0.31, 0.36, 0.5])
    got = asof_nearest(q, t_ref, vals, tolerance_s=0.05)
    want = [np.nan, 10.0, 10.0, 11.0, np.nan, 13.0, np.nan, np.nan]
    np.testing.assert_array_equal(got, want)
