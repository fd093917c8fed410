"""Efficiency (paper eqs. 1-2), masking rules on hand-made points, the gridded map."""

import numpy as np
import pandas as pd
import pytest

from bench.synth.rated_drive import EV_DRIVE, PAPER_DRIVE, grid_points
from fitting.domain import in_polygon, quadrant_envelopes
from fitting.efficiency import (
    ABOVE_MAX,
    CLIPPED,
    NEAR_AXIS,
    NEGATIVE,
    OK,
    OUTSIDE_DOMAIN,
    MaskingRules,
    masked_efficiency,
)
from fitting.efficiency_map import band_shares, gridded_map, peak_points
from fitting.point_uncertainty import point_uncertainty
from fitting.points import quadrant_of
from optimize.paper_model import paper_model

RULES = MaskingRules(nominal_power_w=8200.0, mech_frac=0.02, elec_frac=0.02)  # 164 W


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
    eta, status = masked_efficiency([100.0], [125.0], MaskingRules(8200.0, mech_frac=0.01,
                                                                   elec_frac=0.01))
    assert status[0] == OK and eta[0] == pytest.approx(0.8)
    with pytest.raises(ValueError, match="mech_frac"):
        MaskingRules(8200.0, mech_frac=-0.1)
    d = RULES.to_dict()
    assert d["mech_frac"] == 0.02 and len(d["rules"]) == 7


def _points(speed, torque, p_elec):
    speed, torque = np.asarray(speed, float), np.asarray(torque, float)
    p_mech = speed * 2 * np.pi / 60 * torque
    return pd.DataFrame({"speed_rpm": speed, "torque_nm": torque, "p_mech_w": p_mech,
                         "p_elec_w": np.asarray(p_elec, float), "quadrant": quadrant_of(p_mech)})


def test_map_interpolates_the_loss_inside_the_envelope_and_never_outside():
    # Motor points on a triangle; the loss P_elec - P_mech is linear in speed and
    # torque, so linear interpolation over the triangulation reproduces it exactly
    # (rtol 1e-9), and P_elec = omega T + loss at every node.
    rng = np.random.default_rng(3)
    s = np.concatenate([[100, 1500, 100], rng.uniform(100, 1500, 200)])
    t = np.concatenate([[5, 5, 75], rng.uniform(5, 75, 200)])
    keep = (s - 100) / 1400 + (t - 5) / 70 <= 1  # inside the triangle
    s, t = s[keep], t[keep]
    loss = lambda s, t: 500 + 0.5 * s + 40 * t  # noqa: E731
    p_mech = s * 2 * np.pi / 60 * t
    m = gridded_map(_points(s, t, p_mech + loss(s, t)), RULES, speed_step_rpm=50,
                    torque_step_nm=2)
    inside = m[m["in_domain"]]
    assert len(inside) > 100
    # the nodes are the interpolant, except where a point's cell is cut by the envelope's
    # edge: a reader renormalises the bilinear weights over the cell's in-domain nodes, and
    # those nodes are moved (up to 6 % here) so that every point reads within its uncertainty
    exact = np.isclose(inside["loss_w"], loss(inside["speed_rpm"], inside["torque_nm"]),
                       rtol=1e-9)
    assert exact.mean() > 0.7
    np.testing.assert_allclose(inside["loss_w"], loss(inside["speed_rpm"],
                                                      inside["torque_nm"]), rtol=0.08)
    np.testing.assert_allclose(inside["p_elec_w"], inside["p_mech_w"] + inside["loss_w"],
                               rtol=1e-12)
    # nodes beyond the hypotenuse are outside the envelope: NaN, flagged, never filled
    beyond = (m["speed_rpm"] - 100) / 1400 + (m["torque_nm"] - 5) / 70 > 1 + 1e-6
    assert beyond.sum() > 100
    assert m.loc[beyond, "p_elec_w"].isna().all()
    assert (m.loc[beyond, "status"] == OUTSIDE_DOMAIN).all()
    assert m.loc[beyond, "eta"].isna().all()


def test_band_shares_and_peak_on_the_paper_model():
    # Noise-free points from the paper's model: the gridded map's peak efficiency
    # must match the model's own peak over the same domain (interpolation error of a
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
        sub = m[(m["quadrant"] == q) & m["in_domain"]]
        k = sub["eta_fit"].idxmax()
        assert peaks[q]["map"]["eta"] == pytest.approx(sub.at[k, "eta_fit"], abs=0.01)
        # the surface is flat near its top, so check the place by its true efficiency
        at = sub[(sub["speed_rpm"] == peaks[q]["map"]["speed_rpm"])
                 & (sub["torque_nm"] == peaks[q]["map"]["torque_nm"])]
        assert at["eta_fit"].item() >= sub.at[k, "eta_fit"] - 0.01
        assert peaks[q]["measured"]["eta"] <= 1.0
        # noise-free points: the ceiling is the measured maximum itself
        assert peaks[q]["map"]["eta"] <= peaks[q]["measured"]["eta"] + 1e-12
    # docs/paper_figures.md §1: eta_gen at -1500 rpm, 78 N m about 0.90 (11.04 of 12.25 kW)
    node = m[(m["speed_rpm"] == -1500) & (m["torque_nm"] == 78)]
    assert node["eta_fit"].item() == pytest.approx(11.04 / 12.25, abs=0.005)
    assert node["eta"].item() == pytest.approx(11.04 / 12.25, abs=0.005)
    # the paper's white region: at -50 rpm and 60..78 N m the drive still draws
    # 210..279 W (> the 164 W threshold) while driven: eta < 0 -> 0 (where measured)
    low = m[(m["speed_rpm"] == -50) & (m["torque_nm"] >= 60) & m["in_domain"]]
    assert len(low) >= 5
    assert (low["status"] == NEGATIVE).all() and (low["eta"] == 0).all()


def test_envelope_polygon_follows_band_extremes():
    # motor: a rectangle's corners plus an interior point, bands of 15 rpm (1 % of
    # 1500) -> the rectangle; generator: only 2 points -> no area, left out
    frame = _points([100, 1500, 1500, 100, 800, -100, -3000],
                    [1, 1, 78, 78, 40, 10, 10], [1] * 7)
    env = quadrant_envelopes(frame, band_frac=0.01)
    assert set(env) == {"motor"} and env["motor"]["band_width_rpm"] == pytest.approx(15.0)
    poly = env["motor"]["polygon"]
    # the band at 800 rpm holds one point: the region pinches to it there
    inside = in_polygon(poly, [800, 100, 1500, 50, 450, 450], [40, 1, 78, 40, 58.8, 70])
    assert list(inside) == [True, True, True, False, True, False]
    # at 450 rpm the upper edge is the chord (100, 78)-(800, 40): 59.0 N m
    assert in_polygon(poly, 450, 59.0) and not in_polygon(poly, 450, 59.2)


def _hull_contains(points_xy, query_xy):
    """Convex-hull membership (what the map used before), for contrast."""
    from scipy.spatial import Delaunay
    return Delaunay(points_xy).find_simplex(query_xy) >= 0


def test_non_convex_power_limited_envelope_is_never_filled():
    # A 150 kW, 12000 rpm drive, constant power above 4000 rpm (drive_truth.EV_DRIVE),
    # measured on 24 speed levels x 12 torque steps per quadrant with 300 W noise.
    drive = EV_DRIVE
    noise_w = 300.0
    pts = grid_points(drive, n_speeds=24, n_torques=12, noise_w=noise_w, seed=1)
    rules = MaskingRules(drive.rating.nominal_power_w)
    m = gridded_map(pts, rules)
    shown = m["status"].isin((OK, CLIPPED)).to_numpy()
    speed, torque = m["speed_rpm"].to_numpy(), m["torque_nm"].to_numpy()
    # Tolerance: the envelope's upper edge is the chord between neighbouring speed
    # levels' top points, which lies below the true limit one level spacing slower.
    level_step = 0.96 * drive.rating.max_speed_rpm / 23 * 1.2  # spacing incl. +-10 % jitter
    limit = drive.rating.largest_torque_nm(np.maximum(np.abs(speed) - level_step, 1.0))
    assert not np.any(shown & (torque > limit + 1e-9))
    # the convex hull would have drawn a large unmeasured region (the test can fail)
    for q, sign in (("motor", 1), ("generator", -1)):
        sub = pts[pts["quadrant"] == q]
        xy = np.column_stack([sub["speed_rpm"] / 1e4, sub["torque_nm"] / 1e2])
        hull = _hull_contains(xy, np.column_stack([speed / 1e4, torque / 1e2]))
        above = hull & (torque > drive.rating.largest_torque_nm(speed) + 5.0) & (sign * speed > 0)
        assert above.sum() > 0.1 * ((m["quadrant"] == q) & shown).sum()
    # peak: within 0.005 of the truth's peak over the measured region (noise of the
    # maximum: 300 W / 100 kW = 0.003), and never above measured max + its noise
    eta_pts = np.where(pts["p_mech_w"] > 0, pts["p_mech_w"] / pts["p_elec_w"],
                       pts["p_elec_w"] / pts["p_mech_w"])
    for q in ("motor", "generator"):
        sel = ((m["quadrant"] == q).to_numpy() & shown)
        true_peak = np.nanmax(drive.eta(speed[sel], torque[sel]))
        map_peak = m["eta"].to_numpy()[sel].max()
        assert map_peak == pytest.approx(true_peak, abs=0.005)
        qp = (pts["quadrant"] == q).to_numpy()
        k = np.argmax(np.where(qp, eta_pts, -np.inf))
        # the table states no std: the point's uncertainty is the instruments' accuracy
        # (0.2 % of each power), sqrt(2) * 0.2 % of eta
        noise = eta_pts[k] * np.sqrt(2.0) * rules.accuracy_frac
        assert point_uncertainty(pts, rules)[k] == pytest.approx(noise, rel=1e-12)
        assert map_peak <= eta_pts[k] + noise + 1e-12
        # away from the axes (|P_mech| > 10 % of nominal) every node within 4 noise
        # standard deviations (in eta: 300 W / |P_mech|) plus 0.003 (interpolation of
        # the smooth loss between set points) of the truth
        p_mech = np.abs(m["p_mech_w"].to_numpy())
        big = sel & (p_mech > 0.1 * drive.rating.nominal_power_w)
        err = np.abs(m["eta"].to_numpy()[big] - drive.eta(speed[big], torque[big]))
        assert np.all(err <= 4 * noise_w / p_mech[big] + 0.003)


def test_coarse_grid_never_invents_efficiency():
    # 3 speeds x 3 torques in the motor quadrant, noise-free. Interpolating P_elec
    # linearly and dividing the node's exact omega*T by it (the old map) shows
    # efficiencies up to ~1 where the measured corners reach 0.967: P_mech is
    # bilinear, so along a cell diagonal it exceeds the interpolated corner powers.
    from scipy.interpolate import LinearNDInterpolator
    drive = PAPER_DRIVE
    s, t = np.meshgrid([150.0, 800.0, 1450.0], [5.0, 40.0, 75.0])
    s, t = s.ravel(), t.ravel()
    p_elec = drive.p_elec_w(s, t)
    frame = _points(s, t, p_elec)
    m = gridded_map(frame, RULES, speed_step_rpm=25, torque_step_nm=1)
    measured_max = float(np.max(drive.eta(s, t)))
    old = LinearNDInterpolator(np.column_stack([s / 1450, t / 75]), p_elec)(
        np.column_stack([m["speed_rpm"] / 1450, m["torque_nm"] / 75]))
    eta_old = m["p_mech_w"].to_numpy() / old
    assert np.nanmax(np.where(eta_old <= 1, eta_old, np.nan)) > 0.99
    shown = m["status"].isin((OK, CLIPPED)).to_numpy()
    assert shown.sum() > 3000
    assert m["eta"].to_numpy()[shown].max() <= measured_max + 1e-12
    # with the loss interpolated, nodes with |P_mech| > 10 % of nominal are within
    # 0.02 of the truth (loss curvature over a 650 rpm x 35 N m cell)
    big = shown & (m["p_mech_w"].to_numpy() > 0.1 * drive.rating.nominal_power_w)
    err = np.abs(m["eta"].to_numpy()[big] - drive.eta(m["speed_rpm"][big], m["torque_nm"][big]))
    assert err.max() < 0.02


def test_domain_excursion_of_a_trajectory():
    # motor-only domain: the 100..1500 rpm x 1..78 N m box. A cycle of 4 equal-time
    # points: two inside, one generating (-1000 rpm, 40 N m: outside, nearest domain
    # point (100, 40), scaled distance 1100 / 1500), one at (1600, 80): distance
    # hypot(100 / 1500, 2 / 78).
    from fitting.domain import domain_excursion
    box = [[100.0, 1.0], [1500.0, 1.0], [1500.0, 78.0], [100.0, 78.0]]
    got = domain_excursion([500, 1000, -1000, 1600], [40, 60, 40, 80], [1, 1, 1, 1],
                           {"motor": box}, (1500.0, 78.0))
    assert got["time_fraction_outside"] == pytest.approx(0.5)
    assert got["n_points_outside"] == 2
    assert (got["worst_speed_rpm"], got["worst_torque_nm"]) == (-1000.0, 40.0)
    assert got["worst_distance"] == pytest.approx(1100 / 1500, rel=1e-12)
    inside = domain_excursion([500], [40], [2.0], {"motor": box}, (1500.0, 78.0))
    assert inside["time_fraction_outside"] == 0.0 and inside["worst_distance"] == 0.0
    assert np.isnan(domain_excursion([500], [40], [1.0], None, (1.0, 1.0))
                    ["time_fraction_outside"])
