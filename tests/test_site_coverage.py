"""How much of a site's wind a grid covers: quantiles, the covering grid, hours left out."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from energy.aep import curve_energy
from energy.site import Histogram, Weibull, covering_stop


@pytest.mark.parametrize("q", [0.1, 0.5, 0.99, 0.995])
def test_weibull_quantile_inverts_the_cdf(q):
    w = Weibull(2.3, 7.1)
    v = w.quantile(q)
    assert v == pytest.approx(7.1 * (-math.log(1 - q)) ** (1 / 2.3), rel=1e-12)  # closed form
    assert float(w.cdf(v)) == pytest.approx(q, rel=1e-12)


def test_histogram_quantile_is_linear_inside_a_bin_and_skips_empty_bins():
    h = Histogram((0.0, 2.0, 4.0, 6.0, 8.0), (0.5, 0.0, 0.25, 0.25))
    assert h.quantile(0.25) == pytest.approx(1.0)
    assert h.quantile(0.5) == pytest.approx(2.0)    # the edge where half the hours end
    assert h.quantile(0.625) == pytest.approx(5.0)  # the empty 2-4 m/s bin holds no hours
    assert h.quantile(0.995) == pytest.approx(8.0 - 2.0 * 0.005 / 0.25)


def test_covering_stop_is_the_first_grid_speed_above_the_energy_quantile():
    from energy.site import energy_share

    site = Weibull.from_mean(2.0, 5.5)
    # 99 % of the wind energy lies below 17.04 m/s: on 4, 5.5, ... the first speed above
    # it is 17.5 (the quadrature of v^3 f(v): tests/test_sizing_decision.py)
    assert covering_stop(site, 4.0, 1.5) == 17.5
    assert energy_share(site, 17.5) < 0.01 <= energy_share(site, 16.0)
    assert covering_stop(site, 4.0, 1.5, ceiling_m_s=12.0) == 11.5  # a cut-out ends it
    assert covering_stop(Weibull.from_mean(2.0, 1.0), 4.0, 1.5) == 5.5  # two speeds at least


def test_hours_below_a_cut_in_inside_the_grid_are_not_left_out():
    site = Weibull.from_mean(2.0, 5.5)
    v = np.array([4.0, 6.0, 8.0])
    below, above = float(site.cdf(4.0)), 1 - float(site.cdf(8.0))
    # draws power at 4 m/s (cut-in inside the grid): the hours below deliver nothing anyway
    e = curve_energy(v, np.array([50.0, -100.0, -300.0]), site, 1000.0)
    assert e.share_left_out == pytest.approx(above, rel=1e-12) and e.grid_m_s == (4.0, 8.0)
    assert e.cut_in_m_s == pytest.approx(4.0 + 2.0 * 50.0 / 150.0)  # the zero crossing
    # delivers at 4 m/s: the hours below the grid are lost to it too, and no cut-in was
    # found (issue 49: the table printed the grid's edge as the cut-in)
    e = curve_energy(v, np.array([-20.0, -100.0, -300.0]), site, 1000.0)
    assert e.share_left_out == pytest.approx(above + below, rel=1e-12)
    assert e.delivers_at_grid_start and e.cut_in_m_s is None


def test_key_results_state_the_share_of_the_site_the_aep_covers(tmp_path):
    from energy_fixtures import WINDS, model_with_covariance, write_optimize_folder

    from drivebench.cli import main
    from reports.render import build_context

    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    assert main(["aep", "--optimize", str(folder), "--rayleigh-mean", "5.5",
                 "--out", str(tmp_path / "aep")]) == 0
    none = tmp_path / "none"
    ctx = build_context(none, none, none, ["bench", "report"], tmp_path / "aep", none)
    row = dict(ctx["headline"])["electrical AEP (elec-lim)"]
    # closed form: Rayleigh of mean 5.5 m/s, c = 2 x 5.5 / sqrt(pi), P(v > x) = exp(-(x/c)^2)
    c = 2 * 5.5 / math.sqrt(math.pi)
    lo, hi = min(WINDS), max(WINDS)
    above, below = math.exp(-((hi / c) ** 2)), 1 - math.exp(-((lo / c) ** 2))
    curves = pd.read_csv(tmp_path / "aep" / "power_curves.csv")
    first = curves[curves["kind"] == "elec-lim"].sort_values("wind_speed_m_s").iloc[0]
    left = above + (below if first["p_elec_w"] < 0 else 0.0)  # delivers at the grid's start
    from energy.site import energy_share, rayleigh

    site = rayleigh(5.5)
    energy = energy_share(site, hi) + (energy_share(site, 0.0, lo) if first["p_elec_w"] < 0
                                       else 0.0)
    assert (f"wind grid {lo:g}-{hi:g} m/s covers {100 * (1 - energy):.1f} % of the site's wind "
            f"energy ({100 * (1 - left):.1f} % of its hours)") in row
    assert ("only part of the site's AEP" in row) == (energy > 0.01)  # 4-10 m/s: 39 % above
