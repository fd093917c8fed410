"""Efficiency (paper eqs. 1-2), masking rules on hand-made points, the gridded map."""

import numpy as np
import pandas as pd
import pytest

from fitting.domain import in_polygon_hull, quadrant_hulls
from fitting.efficiency import (
    ABOVE_MAX,
    NEAR_AXIS,
    NEGATIVE,
    OK,
    OUTSIDE_HULL,
    MaskingRules,
    band_shares,
    gridded_map,
    masked_efficiency,
    peak_points,
)
from fitting.model_file import paper_model
from fitting.points import quadrant_of

RULES = MaskingRules(mech_frac=0.02, elec_frac=0.02, nominal_power_w=8200.0)  # 164 W


def test_masking_rules_on_hand_made_points():
    # (P_mech, P_elec) -> expected eta, status; worked out by hand from eqs. (1), (2)
    cases = [
        (1000.0, 1250.0, 0.8, OK),            # motor: 1000 / 1250
        (-1000.0, -900.0, 0.9, OK),           # generator: 900 / 1000
        (-1000.0, 300.0, 0.0, NEGATIVE),      # driven but drawing power: -0.3 -> 0
        (1000.0, -300.0, 0.0, NEGATIVE),      # driving but feeding the grid -> 0
        (100.0, 400.0, np.nan, NEAR_AXIS),    # |P_mech| = 100 W < 164 W
        (-2000.0, -150.0, np.nan, NEAR_AXIS), # |P_elec| = 150 W < 164 W
        (1000.0, 900.0, np.nan, ABOVE_MAX),   # 1.11 > 1: impossible, masked
        (-1000.0, -1000.0, 1.0, OK),          # exactly 1 is allowed
    ]
    p_mech = np.array([c[0] for c in cases])
    p_elec = np.array([c[1] for c in cases])
    eta, status = masked_efficiency(p_mech, p_elec, RULES)
    np.testing.assert_allclose(eta, [c[2] for c in cases], rtol=1e-15)  # NaN == NaN here
    assert list(status) == [c[3] for c in cases]


def test_thresholds_are_configurable():
    # the same 100 W point is kept with a 1 % (82 W) threshold
    eta, status = masked_efficiency([100.0], [125.0], MaskingRules(mech_frac=0.01,
                                                                   elec_frac=0.01))
    assert status[0] == OK and eta[0] == pytest.approx(0.8)
    with pytest.raises(ValueError, match="mech_frac"):
        MaskingRules(mech_frac=-0.1)
    d = RULES.to_dict()
    assert d["mech_frac"] == 0.02 and len(d["rules"]) == 5


def _points(speed, torque, p_elec):
    speed, torque = np.asarray(speed, float), np.asarray(torque, float)
    p_mech = speed * 2 * np.pi / 60 * torque
    return pd.DataFrame({"speed_rpm": speed, "torque_nm": torque, "p_mech_w": p_mech,
                         "p_elec_w": np.asarray(p_elec, float), "quadrant": quadrant_of(p_mech)})


def test_map_interpolates_inside_the_hull_and_never_outside():
    # Motor points on a triangle; P_elec linear in speed and torque, so linear
    # interpolation over the triangulation reproduces it exactly (rtol 1e-9).
    rng = np.random.default_rng(3)
    s = np.concatenate([[100, 1500, 100], rng.uniform(100, 1500, 200)])
    t = np.concatenate([[5, 5, 75], rng.uniform(5, 75, 200)])
    keep = (s - 100) / 1400 + (t - 5) / 70 <= 1  # inside the triangle
    s, t = s[keep], t[keep]
    truth = lambda s, t: 500 + 0.5 * s + 40 * t  # noqa: E731
    m = gridded_map(_points(s, t, truth(s, t)), RULES, speed_step_rpm=50, torque_step_nm=2)
    inside = m[m["in_hull"]]
    np.testing.assert_allclose(inside["p_elec_w"], truth(inside["speed_rpm"],
                                                         inside["torque_nm"]), rtol=1e-9)
    # nodes beyond the hypotenuse are outside the hull: NaN, flagged, never filled
    beyond = (m["speed_rpm"] - 100) / 1400 + (m["torque_nm"] - 5) / 70 > 1 + 1e-6
    assert beyond.sum() > 100
    assert m.loc[beyond, "p_elec_w"].isna().all()
    assert (m.loc[beyond, "status"] == OUTSIDE_HULL).all()
    assert m.loc[beyond, "eta"].isna().all()


def test_band_shares_and_peak_on_the_paper_model():
    # Noise-free points from the paper's model: the gridded map's peak efficiency
    # must match the model's own peak over the same hull (interpolation error of a
    # smooth surface on ~1200 points: 0.01 in eta).
    model = paper_model()
    rng = np.random.default_rng(5)
    corners_s = [50, 1500, 1500, 50, -20, -1500, -1500, -20]
    corners_t = [0, 0, 78, 78, 0, 0, 78, 78]
    s = np.concatenate([rng.uniform(50, 1500, 600), rng.uniform(-1500, -20, 600), corners_s])
    t = np.concatenate([rng.uniform(0, 78, 1200), corners_t])
    frame = _points(s, t, model.p_elec_w(s, t))
    m = gridded_map(frame, RULES, model=model, speed_step_rpm=25, torque_step_nm=1)
    shares = band_shares(m)
    for q in ("motor", "generator"):
        assert shares[shares["quadrant"] == q]["area_share"].sum() == pytest.approx(1.0)
    peaks = peak_points(m, frame, RULES)
    for q in ("motor", "generator"):
        sub = m[(m["quadrant"] == q) & m["in_hull"]]
        k = sub["eta_fit"].idxmax()
        assert peaks[q]["map"]["eta"] == pytest.approx(sub.at[k, "eta_fit"], abs=0.01)
        # the surface is flat near its top, so check the place by its true efficiency
        at = sub[(sub["speed_rpm"] == peaks[q]["map"]["speed_rpm"])
                 & (sub["torque_nm"] == peaks[q]["map"]["torque_nm"])]
        assert at["eta_fit"].item() >= sub.at[k, "eta_fit"] - 0.01
        assert peaks[q]["measured"]["eta"] <= 1.0
    # REFERENCE.md §1: eta_gen at -1500 rpm, 78 N m about 0.90 (11.04 of 12.25 kW)
    node = m[(m["speed_rpm"] == -1500) & (m["torque_nm"] == 78)]
    assert node["eta_fit"].item() == pytest.approx(11.04 / 12.25, abs=0.005)
    assert node["eta"].item() == pytest.approx(11.04 / 12.25, abs=0.005)
    # the paper's white region: at -50 rpm and 60..78 N m the drive still draws
    # 210..279 W (> the 164 W threshold) while driven: eta < 0 -> 0
    low = m[(m["speed_rpm"] == -50) & (m["torque_nm"] >= 60)]
    assert (low["status"] == NEGATIVE).all() and (low["eta"] == 0).all()


def test_hull_polygons():
    # motor: a rectangle's corners plus an interior point -> the 4 corners;
    # generator: only 2 points -> no area, left out of the domain
    frame = _points([100, 1500, 1500, 100, 800, -100, -3000],
                    [1, 1, 78, 78, 40, 10, 10], [1] * 7)
    hulls = quadrant_hulls(frame)
    assert set(hulls) == {"motor"}
    corners = {(100.0, 1.0), (1500.0, 1.0), (1500.0, 78.0), (100.0, 78.0)}
    assert {(round(a, 9), round(b, 9)) for a, b in hulls["motor"]} == corners
    inside = in_polygon_hull(hulls["motor"], [800, 100, 1500, 50, 800], [40, 1, 78, 40, 79])
    assert list(inside) == [True, True, True, False, False]
