"""Annual energy of power curves under wind distributions (energy.site, energy.aep)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate

from energy.aep import aep_mwh, aep_sensitivity, curve_energy, delivered_knots
from energy.site import Histogram, Shear, Weibull, rayleigh, read_histogram_csv
from kernel.errors import InputError


def test_flat_curve_under_weibull_has_the_closed_form():
    # P delivered between v_in and v_out: E = P (exp(-(vin/c)^k) - exp(-(vout/c)^k)).
    # The knots are exact, so only rounding separates the two (rtol 1e-12).
    k, c, p_w, vin, vout = 2.3, 6.7, 5000.0, 3.5, 14.0
    wind = np.linspace(vin, vout, 9)
    got = aep_mwh(wind, np.full_like(wind, -p_w), Weibull(k, c))
    truth = p_w * (math.exp(-((vin / c) ** k)) - math.exp(-((vout / c) ** k))) * 8760 / 1e6
    assert got == pytest.approx(truth, rel=1e-12)


def test_rayleigh_is_weibull_k2_with_scale_from_the_mean():
    r = rayleigh(5.5)
    assert r.k == 2.0
    assert r.scale_m_s == pytest.approx(2 * 5.5 / math.sqrt(math.pi), rel=1e-15)
    # its mean, by the partial moment at infinity, is the given mean
    assert float(r.partial_mean(1e4)) == pytest.approx(5.5, rel=1e-12)
    wind, p = np.array([4.0, 7.0, 10.0]), np.array([-100.0, -900.0, -2000.0])
    assert aep_mwh(wind, p, r) == pytest.approx(aep_mwh(wind, p, Weibull.from_mean(2, 5.5)),
                                                rel=1e-12)


def test_weibull_from_mean_reproduces_the_mean():
    w = Weibull.from_mean(1.7, 6.2)
    assert w.mean_m_s == pytest.approx(6.2, rel=1e-14)
    assert float(w.partial_mean(1e4)) == pytest.approx(6.2, rel=1e-10)


def _interp_delivered(wind, p):
    kv, kd = delivered_knots(wind, p)
    return lambda v: float(np.interp(v, kv, kd, left=0.0, right=0.0))


def test_sloped_curve_matches_numerical_quadrature():
    # independent truth: scipy quad of the interpolated curve times the Weibull pdf
    k, c = 2.0, 6.2
    wind = np.array([4.0, 5.5, 7.0, 8.5, 10.0])
    p = np.array([150.0, -400.0, -1500.0, -2300.0, -2600.0])  # consumes at 4 m/s
    d = _interp_delivered(wind, p)

    def pdf(v):
        return k / c * (v / c) ** (k - 1) * math.exp(-((v / c) ** k))

    kv, _ = delivered_knots(wind, p)
    truth = sum(integrate.quad(lambda v: d(v) * pdf(v), a, b, epsabs=0, epsrel=1e-12)[0]
                for a, b in zip(kv[:-1], kv[1:], strict=True))
    assert aep_mwh(wind, p, Weibull(k, c)) == pytest.approx(truth * 8760 / 1e6, rel=1e-9)


def test_zero_crossing_is_linear_or_the_bisected_cut_in():
    wind, p = np.array([4.0, 5.0, 6.0]), np.array([100.0, -300.0, -500.0])
    kv, kd = delivered_knots(wind, p)
    np.testing.assert_allclose(kv, [4.0, 4.25, 5.0, 6.0])
    np.testing.assert_allclose(kd, [0.0, 0.0, 300.0, 500.0])
    kv, _ = delivered_knots(wind, p, cut_in_m_s=4.6)
    np.testing.assert_allclose(kv, [4.0, 4.6, 5.0, 6.0])
    e = curve_energy(wind, p, rayleigh(5.5), 8200.0, cut_in_m_s=4.6)
    assert e.cut_in_m_s == pytest.approx(4.6)
    assert e.cut_out_m_s == 6.0
    assert e.share_above_grid == pytest.approx(math.exp(-math.pi / 4 * (6 / 5.5) ** 2), rel=1e-12)


def test_sensitivity_is_the_linear_weights_of_the_aep():
    # without a sign change the AEP is linear and homogeneous in the grid powers:
    # sum_i (dAEP/dP_i) P_i = AEP exactly
    wind = np.array([4.0, 5.5, 7.0, 8.5, 10.0])
    p = np.array([-100.0, -400.0, -1500.0, -2300.0, -2600.0])
    site = Weibull(2.0, 6.2)
    s = aep_sensitivity(wind, p, site)
    assert float(s @ p) == pytest.approx(aep_mwh(wind, p, site), rel=1e-9)


def test_binned_weibull_histogram_converges_to_the_weibull():
    w = Weibull(2.1, 6.0)
    edges = np.linspace(0.0, 40.0, 4001)
    probs = np.diff(w.cdf(edges))
    h = Histogram(tuple(edges), tuple(probs / probs.sum()))
    wind = np.array([4.0, 5.5, 7.0, 8.5, 10.0])
    p = np.array([-100.0, -400.0, -1500.0, -2300.0, -2600.0])
    # uniform density within 0.01 m/s bins: the error is O(bin^2), below 1e-5 here
    assert aep_mwh(wind, p, h) == pytest.approx(aep_mwh(wind, p, w), rel=1e-5)


def test_shear_profile_is_the_kite_models():
    # v(h) / v_ref of optimize.model.aero.wind_speed, by hand: log ln((h + z0) / z0) / ln(h_ref /
    # z0), power (h / h_ref)^a
    log = Shear(100.0, "log", 0.1, None)
    assert log.profile(50.0) == pytest.approx(math.log(501) / math.log(1000), rel=1e-12)
    power = Shear(100.0, "power", None, 0.14)
    assert power.profile(10.0) == pytest.approx(0.1 ** 0.14, rel=1e-12)
    with pytest.raises(ValueError, match="above ground"):
        log.profile(0.0)


def test_histogram_csv_edges_and_hours(tmp_path):
    f = tmp_path / "h.csv"
    f.write_text("# measured at 100 m\nv_low_m_s,v_high_m_s,hours\n0,2,1000\n2,4,3000\n"
                 "4,6,4760\n")
    h = read_histogram_csv(f)
    assert h.edges_m_s == (0.0, 2.0, 4.0, 6.0)
    np.testing.assert_allclose(h.probabilities, np.array([1000, 3000, 4760]) / 8760)


def test_histogram_csv_centres_and_probabilities(tmp_path):
    f = tmp_path / "h.csv"
    f.write_text("v_m_s,probability\n1,0.25\n3,0.5\n5,0.25\n")
    h = read_histogram_csv(f)
    assert h.edges_m_s == (0.0, 2.0, 4.0, 6.0)
    assert h.mean_m_s == pytest.approx(3.0)


@pytest.mark.parametrize(
    ("text", "line", "column", "fragment"),
    [
        ("v_low_m_s,v_high_m_s,hours\n0,2,10\n3,4,10\n", 3, "v_low_m_s", "previous ended"),
        ("v_m_s,probability\n1,0.5\n1,0.5\n", 3, "v_m_s", "not above"),
        ("v_m_s,probability\n1,0.5\n3,abc\n", 3, "probability", "not a number"),
        ("v_m_s,probability\n1,0.5\n3,0.2\n", None, "probability", "sum to"),
        ("v_m_s,hours,probability\n1,3,0.5\n", 1, None, "'hours'/'probability'"),
        ("speed,hours\n1,3\n", 1, None, "no wind-speed column"),
        ("v_m_s,hours\n1,-3\n2,4\n", 2, "hours", ">= 0"),
    ],
)
def test_histogram_csv_bad_input_names_line_and_column(tmp_path, text, line, column, fragment):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(InputError) as exc:
        read_histogram_csv(f)
    assert exc.value.line == line
    assert exc.value.column == column
    assert fragment in exc.value.problem
    assert exc.value.path == f


def test_site_height_moves_by_the_systems_wind_profile(tmp_path):
    import argparse

    from energy.cli import add_site_arguments, shear_from_args, site_from_args
    from optimize.system.system import shipped_system_path
    from optimize.system.system_file import load_system

    parser = argparse.ArgumentParser()
    add_site_arguments(parser)
    args = parser.parse_args(["--weibull-k", "2", "--weibull-scale", "6", "--height-m", "10"])
    # a power-law system: the site's scale moves by (h_ref / 10 m)^a, the kite model's profile
    text = shipped_system_path().read_text()
    text = text.replace('profile = "log"', 'profile = "power"')
    text = "\n".join("exponent = 0.2" if line.startswith("roughness_length_m") else line
                     for line in text.splitlines())
    path = tmp_path / "power.toml"
    path.write_text(text)
    system = load_system(path)
    site, note, _ = site_from_args(args, shear_from_args(args, system))
    h_ref = system.wind.reference_height_m
    assert site.scale_m_s == pytest.approx(6.0 * (h_ref / 10.0) ** 0.2, rel=1e-12)
    assert "power-law shear exponent 0.2" in note
    # the shipped (log) system, unless --roughness-m says otherwise
    site, _, _ = site_from_args(args, shear_from_args(args, load_system()))
    assert site.scale_m_s == pytest.approx(6.0 * math.log(1001) / math.log(101), rel=1e-12)


def test_capacity_factor_rating_is_the_drive_in_force_of_the_sweep():
    from energy.assess import NOMINAL_SOURCES, nominal_power
    from optimize.sweep_folder import sweep_drive

    model = {"nominal_power_w": 18923.0, "drive": {"nominal_power_w": 18923.0}}
    in_force = sweep_drive({"sections": {"drive": {"nominal_power_w": 18920.0}}})
    # the rating the optimize manifest names wins over the power model's own
    assert nominal_power(model, None, None, in_force) == (18920.0, NOMINAL_SOURCES[1])
    # the user's value wins over both; a sweep without the record falls back to the model
    assert nominal_power(model, 5000.0, None, in_force) == (5000.0, NOMINAL_SOURCES[0])
    assert sweep_drive({}) is None
    assert nominal_power(model, None, None, None) == (18923.0, NOMINAL_SOURCES[2])
    # a record that is not a drive is refused, naming the manifest and the key
    with pytest.raises(InputError, match=r"manifest.json.*sections\.drive\.nominal_power_w"):
        sweep_drive({"sections": {"drive": {"nominal_power_w": "18 kW"}}}, Path("opt"))
