"""What the figures show apart (issue 42): Fig. 9(a)'s measured envelope in a colour no
cycle has; Fig. 6's fit contours solid below zero (dashed is the measured data's); the
efficiency map's title over its own panel; the power curves of a sweep drawn."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.colors import to_hex  # noqa: E402

from energy.plots import plot_power_curves  # noqa: E402
from fitting.figures import draw_power_map  # noqa: E402
from kernel.figure_text import overflowing_text  # noqa: E402
from optimize.paper_model import paper_model  # noqa: E402
from optimize.plots import SCENARIO_COLORS, plot_efficiency_map  # noqa: E402


def _map() -> pd.DataFrame:
    """An efficiency map over both quadrants: eta falls from 0.9 towards the axes."""
    s, t = np.meshgrid(np.linspace(-1500, 1500, 31), np.linspace(0, 78, 14))
    eta = 0.9 - 0.3 * np.exp(-np.abs(s) / 300) - 0.3 * np.exp(-t / 10)
    return pd.DataFrame({"speed_rpm": s.ravel(), "torque_nm": t.ravel(), "eta": eta.ravel()})


def _cycle(scale: float) -> pd.DataFrame:
    t = np.linspace(0, 5, 51)
    return pd.DataFrame({"time_s": t, "speed_rpm": scale * 1000 * np.sin(t),
                         "torque_nm": 40 + scale * 20 * np.cos(t)})


def test_fig9_measured_envelope_has_a_colour_no_cycle_has():
    domain = {"motor": [[10, 1], [1400, 1], [1400, 70], [10, 70]],
              "generator": [[-1400, 1], [-10, 1], [-10, 70], [-1400, 70]]}
    ax = plot_efficiency_map(_map(), domain=domain,
                             cycles={k: _cycle(0.5 + 0.1 * i) for i, k in
                                     enumerate(SCENARIO_COLORS)})
    lines = {line.get_gid(): to_hex(line.get_color()) for line in ax.lines if line.get_gid()}
    envelope = lines.pop("measured-envelope")
    assert set(lines) == {f"cycle-{k}" for k in SCENARIO_COLORS}
    assert envelope not in set(lines.values())  # it was mech-lim's red
    plt.close(ax.figure)


def test_fig6_fit_contours_are_solid_below_zero():
    model = paper_model()
    s, t = np.meshgrid(np.linspace(-1500, 1500, 25), np.linspace(1, 78, 12))
    s, t = s.ravel(), t.ravel()
    points = pd.DataFrame({"speed_rpm": s, "torque_nm": t, "p_elec_w": model.p_elec_w(s, t),
                           "quadrant": np.where(s > 0, "motor", "generator")})
    fig, ax = plt.subplots()
    draw_power_map(ax, model, points)
    black = [c for c in ax.collections if hasattr(c, "levels")
             and np.allclose(c.get_edgecolor()[:, :3], 0.0)]
    red = [c for c in ax.collections if hasattr(c, "levels") and c not in black]
    assert black and red and min(black[0].levels) < 0  # the fit's levels go below zero
    assert all(dashes is None for c in black for _, dashes in c.get_linestyle())
    assert all(dashes is not None for c in red for _, dashes in c.get_linestyle())
    plt.close(fig)


def test_efficiency_map_title_stays_over_its_own_panel():
    # the docs' two-panel example: the title spilled over the next panel
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.5), layout="constrained")
    plot_efficiency_map(_map(), a)
    b.plot([0, 1], [0, 1])
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    title = a.title.get_window_extent(renderer)
    assert title.x1 <= b.get_window_extent(renderer).x0
    assert title.x0 >= 0 and overflowing_text(fig) == []
    plt.close(fig)
    ax = plot_efficiency_map(_map())  # a figure of its own
    assert overflowing_text(ax.figure) == []
    plt.close(ax.figure)


def test_power_curves_of_a_sweep_are_drawn_as_the_docs_say():
    # db.plot_power_curves(sweep.curves) failed: 'dict' object has no attribute 'groupby'
    from energy.curve import PowerCurve

    w = np.array([5.0, 7.0, 9.0])
    curve = PowerCurve("elec-lim", "electrical", True, w, -100.0 * w, -120.0 * w,
                       np.full(3, 8.0), np.full(3, 900.0), np.full(3, 78.0),
                       ("elec-lim-5.0", "elec-lim-7.0", "elec-lim-9.0"))
    ax = plot_power_curves({"elec-lim": curve})
    (elec, mech) = ax.lines[:2]
    np.testing.assert_allclose(elec.get_ydata(), 100.0 * w)  # delivered = -P
    np.testing.assert_allclose(mech.get_ydata(), 120.0 * w)
    plt.close(ax.figure)


def test_efficiency_map_title_is_one_line_over_a_panel_of_a_grid():
    # issue 49: the title wrapped into three lines ("...blank:" / "outside" / "the measured
    # envelope)") and, in a subplot through the API, its top was cut off the figure
    fig, axes = plt.subplots(2, 2, figsize=(9, 6))
    plot_efficiency_map(_map(), axes[0, 0], masking={"mech_frac": 0.05, "elec_frac": 0.05})
    fig.canvas.draw()
    assert "\n" not in axes[0, 0].get_title()
    assert overflowing_text(fig) == []
    # the masking rule the title once carried is in the legend
    labels = [t.get_text() for t in axes[0, 0].get_legend().get_texts()]
    assert "white: negative, or masked: |P_mech| < 0.05 P_nom or |P_elec| < 0.05 P_nom" in labels
    assert "blank: not measured" in labels
    plt.close(fig)


def test_power_curve_legend_names_every_curve():
    # issue 49: the legend named only the electrical curves, the dashed mechanical unnamed
    curves = pd.DataFrame({"kind": ["elec-lim"] * 3 + ["mech-free"] * 3,
                           "wind_speed_m_s": [5.0, 7.0, 9.0] * 2,
                           "p_elec_w": [-100.0, -300.0, -500.0, 50.0, 20.0, -10.0],
                           "p_mech_w": [-200.0, -500.0, -800.0, -300.0, -700.0, -1200.0],
                           "p_elec_sigma_w": [5.0] * 6})
    ax = plot_power_curves(curves)
    drawn = [line for line in ax.lines if len(line.get_xdata()) == 3]
    assert len(drawn) == 4
    named = {line.get_label() for line in ax.get_legend().get_lines()}
    assert all(line.get_label() in named for line in drawn)
    dashed = [line.get_label() for line in drawn if line.get_linestyle() == "--"]
    assert len(dashed) == 2 and all("mechanical" in label for label in dashed)
    plt.close(ax.figure)
