"""Each point's uncertainty includes how well the sessions repeat an operating point, and
the map as shipped (its grid, read bilinearly) shows every accepted point within it.

Synthetic campaigns with a known truth: three sessions measure the same setpoints; each
point's loss carries the window noise the point states (``p_elec_w_std``,
``n_samples``) and a repeat scatter of known standard deviation that no window
statistic shows (the winding temperature differs from visit to visit)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from fitting.efficiency import MaskingRules
from fitting.efficiency_map import gridded_map, map_at
from fitting.map_honesty import points_against_map, read_grid
from fitting.point_uncertainty import REPEAT_COLUMN, efficiency_ceilings
from fitting.points import quadrant_of
from fitting.repeatability import loss_repeatability, with_repeatability

RULES = MaskingRules(nominal_power_w=8200.0)
REPEAT_W = 60.0  # the true repeat scatter of one point's loss [W]
WINDOW_STD_W, N_SAMPLES = 40.0, 100  # stated: a standard error of 4 W per power


def _campaign(sessions: int, seed: int = 1) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    speed, torque = np.meshgrid(np.linspace(200, 1500, 12), np.linspace(10, 78, 10))
    speed, torque = speed.ravel(), torque.ravel()
    frames = []
    for k in range(sessions):
        s = speed + rng.normal(0, 2.0, speed.size)  # a setpoint is held within 2 rpm
        q = torque + rng.normal(0, 0.1, torque.size)
        p_mech = s * 2 * np.pi / 60 * q
        loss = 150 + 0.2 * s + 0.08 * q**2 + rng.normal(0, REPEAT_W, s.size)
        p_elec = p_mech + loss + rng.normal(0, WINDOW_STD_W / np.sqrt(N_SAMPLES), s.size)
        frames.append(pd.DataFrame({
            "session_id": f"s{k}", "speed_rpm": s, "torque_nm": q, "p_mech_w": p_mech,
            "p_elec_w": p_elec, "p_elec_w_std": WINDOW_STD_W, "p_mech_w_std": WINDOW_STD_W,
            "n_samples": N_SAMPLES, "quadrant": quadrant_of(p_mech)}))
    return pd.concat(frames, ignore_index=True)


def test_pooled_repeatability_recovers_the_true_scatter():
    frame = _campaign(3)
    out = loss_repeatability(frame, RULES)
    m = out["motor"]
    assert m["pooled_over"] == "quadrant" and m["n_pairs"] == 3 * 120  # 3 pairs a setpoint
    # 360 pairs (correlated in threes): the pooled estimate's relative standard error is
    # about 1 / sqrt(2 * 240) = 5 %; the stated window errors (4 W per power, 0.2 % of the
    # reading) are removed from it, the tolerance 15 %
    assert m["loss_w"] == pytest.approx(REPEAT_W, rel=0.15)
    assert "note" not in out
    col = with_repeatability(frame, out)[REPEAT_COLUMN]
    assert (col == m["loss_w"]).all()


def test_without_repeats_the_fallback_is_zero_and_said():
    out = loss_repeatability(_campaign(1), RULES)
    assert out["motor"] == {"loss_w": 0.0, "n_pairs": 0, "pooled_over": "none"}
    assert "repeatability not measured" in out["note"]


@pytest.mark.parametrize("sessions", [1, 3])
def test_the_shipped_grid_shows_every_point_within_its_uncertainty(sessions):
    frame = _campaign(sessions)
    frame = with_repeatability(frame, loss_repeatability(frame, RULES))
    # a coarse grid (100 rpm x 5 N m) against points 2 rpm / 0.1 N m apart: read
    # bilinearly, the raw interpolant's nodes miss the points by the repeat scatter
    m = gridded_map(frame, RULES, speed_step_rpm=100, torque_step_nm=5)
    ceilings = m.attrs["ceilings"]
    # independent check: each point's uncertainty in eta from its own numbers (standard
    # error 4 W per power, 0.2 % of each reading, the repeatability on the loss)
    p_mech, p_elec = frame["p_mech_w"].to_numpy(), frame["p_elec_w"].to_numpy()
    eta = p_mech / p_elec
    se = WINDOW_STD_W / np.sqrt(N_SAMPLES)
    rel = np.sqrt(((se**2 + (0.002 * p_elec) ** 2) + frame[REPEAT_COLUMN] ** 2) / p_elec**2
                  + (se**2 + (0.002 * p_mech) ** 2) / p_mech**2)
    u = eta * rel
    ok = (p_mech >= 0.02 * 8200) & (p_elec >= 0.02 * 8200)

    def shown(loss):
        return np.minimum(p_mech / (p_mech + loss), ceilings["motor"]["eta"])

    read = read_grid(m, frame["speed_rpm"], frame["torque_nm"])
    off = ok & ~np.isfinite(read)  # on the envelope's edge, no in-domain node around
    assert off.sum() < 0.1 * ok.sum()
    above = ok & (eta - shown(read) > u + 1e-9)
    assert above.sum() == 0
    # the uncorrected nodes (the interpolant sampled at the nodes) would not: the test
    # can fail
    raw = m[["speed_rpm", "torque_nm"]].assign(loss_w=map_at(
        frame, RULES, m["speed_rpm"], m["torque_nm"], ceilings=ceilings)["loss_w"])
    raw_read = read_grid(raw, frame["speed_rpm"], frame["torque_nm"])
    assert (ok & (eta - shown(raw_read) > u + 1e-9)).sum() > 10
    # the fit's own count agrees; no node shows more than the ceiling
    against = points_against_map(frame, RULES, m, ceilings)["motor"]
    assert against["n_above_map"] == 0 and against["n_off_map"] == off.sum()
    assert m["eta"].max() <= efficiency_ceilings(frame, RULES)["motor"]["eta"]
    if sessions == 3:
        # with the repeat scatter in each point's uncertainty, the repeats disagree as
        # often as chance says (two combined sigmas: ~5 %), not as the window errors do
        from fitting.repeatability import repeatability

        rep = repeatability(frame, RULES)
        assert rep["n_disagreeing"] <= 0.12 * rep["n_pairs"]
        assert rep["n_disagreeing_stated"] >= 0.5 * rep["n_pairs"]
