"""The torque-flange tare (bench.ingest.tare) on series with a known offset."""

from __future__ import annotations

import numpy as np
import pytest

from bench.ingest.tare import GUARD_S, TareFinder

RATE_HZ = 50.0
SPEED_RANGE_RPM, TORQUE_RANGE_NM = 3000.0, 100.0  # standstill below 6 rpm, offsets up to 2 N m


def _session(rng, offset_nm=0.2, tare_s=6.0, load_nm=40.0, standstill_load_nm=0.0):
    """Standstill for ``tare_s`` then a ramp to 500 rpm with ``load_nm``; flange reads + offset.

    The load is applied 0.1 s before the speed leaves standstill (what the guard is for).
    """
    t = np.arange(0.0, tare_s + 10.0, 1.0 / RATE_HZ)
    speed = np.where(t < tare_s, 0.0, np.minimum((t - tare_s) * 200.0, 500.0))
    torque = np.where(t < tare_s - 0.1, standstill_load_nm, load_nm)
    speed = speed + rng.normal(0.0, 0.4, t.size)
    torque = torque + offset_nm + rng.normal(0.0, 0.06, t.size)
    return t, speed, torque


def test_offset_is_the_median_of_the_standstill():
    rng = np.random.default_rng(3)
    t, speed, torque = _session(rng)
    torque[10] = 9.91e37  # an isolated marker the scrubber missed: the median ignores it
    speed[20] = np.nan
    f = TareFinder(SPEED_RANGE_RPM, TORQUE_RANGE_NM)
    f.feed(t, speed, torque)
    tare, why = f.result()
    assert why == ""
    # ~270 samples of 0.06 N m noise: the median's sigma is 1.25 * 0.06 / sqrt(270) = 0.005;
    # the loaded samples before motion (0.1 s) are cut off by the 0.5 s guard
    assert tare.offset_nm == pytest.approx(0.2, abs=0.02)
    assert tare.speed_limit_rpm == pytest.approx(6.0)
    # motion starts when the ramp passes 6 rpm: 0.03 s after the step (+-2 samples of noise)
    assert tare.t_motion_s == pytest.approx(6.03, abs=0.05)
    assert tare.t_end_s <= tare.t_motion_s - GUARD_S and tare.t_start_s == 0.0
    assert tare.n_samples == pytest.approx((tare.t_motion_s - GUARD_S) * RATE_HZ, abs=3)


def test_chunked_feed_equals_whole():
    rng = np.random.default_rng(4)
    t, speed, torque = _session(rng)
    whole = TareFinder(SPEED_RANGE_RPM, TORQUE_RANGE_NM)
    whole.feed(t, speed, torque)
    chunked = TareFinder(SPEED_RANGE_RPM, TORQUE_RANGE_NM)
    for a in range(0, t.size, 37):
        chunked.feed(t[a:a + 37], speed[a:a + 37], torque[a:a + 37])
    assert chunked.result() == whole.result()


@pytest.mark.parametrize(("kwargs", "why"), [
    ({"tare_s": 0.0}, "no standstill"),  # logging starts with the drive already moving
    ({"tare_s": 1.2}, "no standstill"),  # 0.7 s left after the guard: too short
    ({"standstill_load_nm": 5.0}, "a load, not a zero offset"),  # 5.2 N m > 2 % of 100 N m
])
def test_no_tare(kwargs, why):
    rng = np.random.default_rng(5)
    f = TareFinder(SPEED_RANGE_RPM, TORQUE_RANGE_NM)
    f.feed(*_session(rng, **kwargs))
    tare, reason = f.result()
    assert tare is None and why in reason


def test_never_moving_is_no_tare():
    t = np.arange(0.0, 10.0, 1.0 / RATE_HZ)
    f = TareFinder(SPEED_RANGE_RPM, TORQUE_RANGE_NM)
    f.feed(t, np.zeros(t.size), np.full(t.size, 0.1))
    assert f.result() == (None, "the drive never leaves standstill")
