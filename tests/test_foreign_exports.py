"""Exports as another lab writes them: found by trying the tool as a new user.

Each builder writes a single-stream ``[log]`` session with a known truth (steady
holds at chosen speed and torque, p_elec from a plausible loss model); the tests
check what ingest recovers against that truth.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.ingest.pipeline import ingest
from bench.store.read import read_points
from kernel.errors import InputError


def _loss_w(speed_rpm, torque_nm):
    """Plausible drive losses [W]: constant, speed-proportional and copper (T^2) terms."""
    return 25.0 + 0.05 * np.abs(speed_rpm) + 0.8 * np.asarray(torque_nm) ** 2


def make_noisy_fast_log(root: Path, holds: list[tuple[float, float]],
                        stops_at: tuple[int, ...] = (), rate_hz: float = 2000.0,
                        hold_s: float = 6.0, lead_s: float = 3.0,
                        speed_noise_rpm: float = 3.0, seed: int = 1) -> None:
    """A fast logger whose speed encoder is noisy sample to sample (std ``speed_noise_rpm``).

    The session starts with ``lead_s`` at standstill and, before each hold index in
    ``stops_at``, stops for ``hold_s``: standstill, not an operating point.
    """
    rng = np.random.default_rng(seed)
    levels = [(0.0, 0.0)]
    for i, h in enumerate(holds):
        if i in stops_at:
            levels.append((0.0, 0.0))
        levels.append(h)
    durations = [lead_s] + [hold_s] * (len(levels) - 1)
    reps = [int(d * rate_hz) for d in durations]
    n = np.repeat([lv[0] for lv in levels], reps)
    tq = np.repeat([lv[1] for lv in levels], reps)
    t = np.arange(n.size) / rate_hz
    pe = n * np.pi / 30 * tq + _loss_w(n, tq)
    n = n + rng.normal(0, speed_noise_rpm, n.size)
    tq = tq + rng.normal(0, 0.05, n.size)
    pe = pe + rng.normal(0, 5.0, n.size)
    folder = root / "fast"
    folder.mkdir(parents=True)
    (folder / "session.toml").write_text('''session_id = "fast"
kind = "timeseries"
mode = "motor"
operator = "other lab"
date = "2024-03-05"
gear_ratio = 1.0
measured_side = "drum"
speed_sign = 1
torque_sign = 1

[log]
file = "log.csv"
format = "csv"

[sensors]
speed_range_rpm = 3000.0
torque_range_nm = 40.0
power_range_w = 6000.0
''')
    rows = ["Time [s],Speed [rpm],Torque [Nm],P_elec [W]"]
    rows += [f"{a:.5f},{b:.2f},{c:.3f},{d:.1f}" for a, b, c, d in zip(t, n, tq, pe, strict=True)]
    (folder / "log.csv").write_text("\n".join(rows) + "\n")


def test_standstill_of_a_noisy_fast_logger_is_no_operating_point(tmp_path):
    # A 2 kHz log with 3 rpm sample noise (0.1 % of a 3000 rpm sensor): single samples
    # cross the 6 rpm standstill limit, so no tare is found. The leading standstill and a
    # stop between the holds must still not become operating points (speed 0, torque 0,
    # its quadrant decided by the noise's sign): 3 holds give exactly 3 points.
    holds = [(500.0, 10.0), (1200.0, 20.0), (-900.0, 15.0)]
    make_noisy_fast_log(tmp_path / "c", holds, stops_at=(2,))
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = read_points(tmp_path / "store").sort_values("t_start_s")
    assert len(pts) == len(holds)
    # means: 0.5 rpm, 0.05 N m, 5 W are many standard errors of a 6 s hold at 2 kHz
    assert np.allclose(pts.speed_rpm, [h[0] for h in holds], atol=0.5)
    assert np.allclose(pts.torque_nm, [h[1] for h in holds], atol=0.05)
    truth_pe = [h[0] * np.pi / 30 * h[1] + _loss_w(h[0], h[1]) for h in holds]
    assert np.allclose(pts.p_elec_w, truth_pe, atol=5.0)
    assert pts.quadrant.tolist() == ["motor", "motor", "generator"]


def test_fit_too_few_points_for_cross_validation_says_so():
    # A generator-only campaign of 12 points on a 4 x 3 speed-torque grid (well spread)
    # passes the 12-point minimum of a 4-term fit, but 5-fold CV trains on 9 or 10: every
    # candidate is skipped. The error must say that, not ask to spread the points.
    from fitting.selection import select_model

    speed, torque = np.meshgrid([-600.0, -1000.0, -1400.0, -1800.0], [8.0, 15.0, 22.0])
    speed, torque = speed.ravel(), torque.ravel()
    p = speed * np.pi / 30 * torque + _loss_w(speed, torque)
    with pytest.raises(InputError) as err:
        select_model(speed, torque, p, np.full(speed.size, "generator"), np.ones(speed.size),
                     folds=5, nominal_power_w=8200.0)
    msg = str(err.value)
    assert "too few points" in msg and "12 points" in msg, msg
    assert "spread" not in msg, msg


def _session(folder: Path, file: str) -> None:
    folder.mkdir(parents=True)
    (folder / "session.toml").write_text(f'''session_id = "{folder.name}"
kind = "timeseries"
mode = "motor"
operator = "other lab"
date = "2024-03-05"
gear_ratio = 1.0
measured_side = "drum"
speed_sign = 1
torque_sign = 1

[log]
file = "{file}"
format = "csv"

[sensors]
speed_range_rpm = 3000.0
torque_range_nm = 40.0
power_range_w = 6000.0
''')


@pytest.mark.parametrize("units", [("[s]", "[U/min]", "[Nm]", "[kW]"),
                                   ("(s)", "(U/min)", "(Nm)", "(kW)")])
def test_units_row_with_brackets_or_parentheses(tmp_path, units):
    # German loggers often write the units row as '[s];[U/min];[Nm];[kW]' (or with
    # parentheses): the same units as the bare row, so the same points.
    holds = [(500.0, 10.0), (1000.0, 20.0), (-800.0, 15.0)]
    rate, hold_s, lead_s = 10.0, 10.0, 4.0
    levels = [(0.0, 0.0)] + holds
    reps = [int(lead_s * rate)] + [int(hold_s * rate)] * len(holds)
    n = np.repeat([lv[0] for lv in levels], reps)
    tq = np.repeat([lv[1] for lv in levels], reps)
    pe = n * np.pi / 30 * tq + _loss_w(n, tq)
    t = np.arange(n.size) / rate
    rows = ["Zeit;Drehzahl;Drehmoment;Wirkleistung", ";".join(units)]
    rows += [f"{a:.2f};{b:.2f};{c:.3f};{d / 1000:.5f}".replace(".", ",")
             for a, b, c, d in zip(t, n, tq, pe, strict=True)]
    folder = tmp_path / "c" / "de_units"
    _session(folder, "log.csv")
    (folder / "log.csv").write_text("\n".join(rows) + "\n")
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = read_points(tmp_path / "store").sort_values("t_start_s")
    # noise-free holds: the means are the setpoints up to the 5-digit kW rounding (0.005 W)
    assert np.allclose(pts.speed_rpm, [h[0] for h in holds], atol=1e-6)
    assert np.allclose(pts.torque_nm, [h[1] for h in holds], atol=1e-6)
    truth_pe = [h[0] * np.pi / 30 * h[1] + _loss_w(h[0], h[1]) for h in holds]
    assert np.allclose(pts.p_elec_w, truth_pe, atol=0.01)


def test_generator_log_with_p_elec_as_magnitude_names_the_power_sign(tmp_path):
    # A generator-only bench logging speed > 0, torque < 0 (torque_sign = "signed") and the
    # power fed back as a positive number. The signs disagree everywhere; "torque_sign = -1"
    # would turn off "signed" and then fail on efficiency > 1. The error must name the
    # p_elec sign as a cause (and, for a signed session, speed_sign as the sign to flip).
    holds = [(a, -b) for a in (600.0, 1200.0, 1800.0) for b in (8.0, 16.0)]
    rate, hold_s = 2.0, 20.0
    reps = [int(6 * rate)] + [int(hold_s * rate)] * len(holds)
    n = np.repeat([0.0] + [h[0] for h in holds], reps)
    tq = np.repeat([0.0] + [h[1] for h in holds], reps)
    fed_w = np.abs(n * np.pi / 30 * tq) - _loss_w(n, tq)  # generated power, logged positive
    t = np.arange(n.size) / rate
    folder = tmp_path / "c" / "gen_abs"
    _session(folder, "log.csv")
    toml = folder / "session.toml"
    toml.write_text(toml.read_text().replace("torque_sign = 1", 'torque_sign = "signed"'))
    rows = ["Time [s],Speed [rpm],Torque [Nm],P_elec [W]"]
    rows += [f"{a:.1f},{b:.2f},{c:.3f},{d:.1f}" for a, b, c, d in zip(t, n, tq, fed_w, strict=True)]
    (folder / "log.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(InputError) as err:
        ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    msg = str(err.value)
    assert "p_elec" in msg and "positive" in msg and "speed_sign = -1" in msg, msg
    assert "torque_sign = -1" not in msg, msg
