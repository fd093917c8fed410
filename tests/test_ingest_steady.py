"""Steady-state windows on hand-made bin series whose windows and defects are known."""

from __future__ import annotations

import numpy as np
import pytest

from bench.ingest.steady import SteadyConfig, find_windows, noise_sigma, quadrant

RANGES = {"speed": 3000.0, "torque": 100.0, "power": 15000.0}
CFG = SteadyConfig()  # 0.1 s bins, 2 s minimum window


def _series(holds, rng, tau_bins=5.0):
    """Bin means of a staircase: ``holds`` = [(n_bins, speed, torque)], first-order steps."""
    speed, torque = [], []
    prev = holds[0]
    for n, s, q in holds:
        k = np.arange(n)
        e = np.exp(-k / tau_bins)
        speed.append(s + (prev[1] - s) * e)
        torque.append(q + (prev[2] - q) * e)
        prev = (n, s, q)
    speed = np.concatenate(speed) + rng.normal(0, 0.3, sum(h[0] for h in holds))
    torque = np.concatenate(torque) + rng.normal(0, 0.05, speed.size)
    p_elec = 300 + speed * torque * np.pi / 30 + rng.normal(0, 2.0, speed.size)
    return speed, torque, p_elec, np.ones(speed.size)


def test_one_window_per_hold_after_settling():
    rng = np.random.default_rng(0)
    holds = [(60, 300, 10), (60, 300, 40), (80, 900, 40), (60, 900, 70)]
    speed, torque, p, valid = _series(holds, rng)
    w = find_windows(speed, torque, p, valid, RANGES, CFG)
    assert len(w.accepted) == 4 and w.rejected == []
    starts = np.cumsum([0] + [h[0] for h in holds[:-1]])
    assert w.accepted[0][0] == 0  # logging starts on a settled point
    for (a, b), s0, h in zip(w.accepted, starts, holds, strict=True):
        # settled: a 600 rpm step decays to the ~3 rpm tolerance in 5 ln(200) = 27 bins
        assert a == 0 or s0 + 5 <= a <= s0 + 35
        assert b <= s0 + h[0]
        assert abs(np.mean(speed[a:b]) - h[1]) < 0.5  # 0.3 rpm bin noise, > 20 bins
        assert abs(np.mean(torque[a:b]) - h[2]) < 0.1


def test_rejection_reasons():
    rng = np.random.default_rng(1)
    holds = [(60, 300, 10), (30, 500, 10), (60, 700, 20), (60, 900, 30), (60, 1100, 40),
             (60, 1300, 50)]
    speed, torque, p, valid = _series(holds, rng)
    s = np.cumsum([0] + [h[0] for h in holds])
    k = np.arange(s[2], s[3])
    speed[k] += 6.0 * np.sin(2 * np.pi * k / 4)  # 0.4 s oscillation: means stay, std does not
    valid[s[3]:s[4]] = 0.5  # half of the DAQ samples invalid
    kp = np.arange(s[4], s[5])
    p[kp] += 80.0 * np.sin(2 * np.pi * kp / 6)  # electrical power swinging
    w = find_windows(speed, torque, p, valid, RANGES, CFG)
    reasons = [r for _, _, r in w.rejected]
    assert reasons == ["too short", "speed unstable", "invalid samples", "power unstable"]
    assert len(w.accepted) == 2


def test_noise_sigma_and_quadrant():
    rng = np.random.default_rng(3)
    x = np.repeat([0.0, 50.0, 20.0], 2000) + rng.normal(0, 2.0, 6000)
    # robust to the two steps: within 5 % of the true 2.0 (6000 samples)
    assert noise_sigma(x) == pytest.approx(2.0, rel=0.05)
    assert quadrant(np.array([1.0, -1.0, 0.0])).tolist() == ["motor", "generator", "generator"]


def test_blocks_give_the_same_windows(monkeypatch):
    import bench.ingest.steady as steady

    rng = np.random.default_rng(5)
    holds = [(int(rng.integers(70, 120)), float(rng.uniform(100, 1500)),
              float(rng.uniform(1, 78))) for _ in range(60)]
    speed, torque, p, valid = _series(holds, rng)
    whole = find_windows(speed, torque, p, valid, RANGES, CFG)
    monkeypatch.setattr(steady, "BLOCK_BINS", 400)  # ~10 blocks, cut inside transitions
    blocked = find_windows(speed, torque, p, valid, RANGES, CFG)
    assert len(whole.accepted) == len(holds)
    assert blocked.accepted == whole.accepted and blocked.rejected == whole.rejected


@pytest.mark.parametrize(("amp_rpm", "freq_hz"), [(10.0, 0.5), (10.0, 1.0), (40.0, 1.5),
                                                  (40.0, 3.0)])
def test_strong_or_slow_hunting_is_reported_not_lost(amp_rpm, freq_hz):
    # oscillations whose 0.5 s lagged means swing by more than the step threshold (3 x 3 rpm)
    # are cut into pieces too short to report; the stretch is still one rejected window
    rng = np.random.default_rng(2)
    holds = [(60, 300, 10), (60, 300, 20), (60, 300, 30), (60, 300, 40)]
    speed, torque, p, valid = _series(holds, rng)
    k = np.arange(60, 120)
    speed[k] += amp_rpm * np.sin(2 * np.pi * freq_hz * (k - 60) * 0.1)
    w = find_windows(speed, torque, p, valid, RANGES, CFG)
    assert len(w.accepted) == 3
    assert [r for _, _, r in w.rejected] == ["speed unstable"]
    a, b, _ = w.rejected[0]
    # the hunting hold, from 5 bins (the 0.5 s lag) before it to the end of the next step's
    # transient (10 N m, 5-bin time constant: 3 lags + 5 ln(10 / 0.17) = 35 bins at most)
    assert 55 <= a < b <= 155 and b - a >= 20
