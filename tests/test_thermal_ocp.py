"""The winding temperature in the cycle: a periodic state with the drive's thermal limit.

Truths: the closed-form periodic solution of the first-order model under a sinusoidal
heat; the cycle mean of that model (``theta_mean = theta_amb + r_th mean(q)``, exact for
any periodic heat); an independent forward integration (scipy's RK45) of the thermal model
over 50 repeated optimal cycles, its heat recomputed from the trajectory at the simulated
temperature.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from system_fixtures import system_for

from energy.site import Weibull
from energy.sizing import candidate_table, scaled_candidates
from kernel.errors import InputError
from kernel.units import RPM_PER_RAD_S
from optimize.model.drivetrain import carry_power_model
from optimize.model.kite_model import kite_dae
from optimize.model.thermal import STATE, WindingThermal, periodic_temperatures
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp, thermal_line, winding_thermal
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.result import carry_over
from optimize.solve.solve import solve
from optimize.solve.starts.cold import start
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system

#: a thermal block as bench fit writes it (the synthetic campaign's truth: 0.05 K/W, 600 s,
#: copper 0.00393 /K), the power model's copper term holding at 40 degC
THERMAL = {"version": 1, "nodes": 1, "r_th_k_per_w": 0.05, "tau_th_s": 600.0,
           "c_th_j_per_k": 12000.0, "copper_temp_coeff_per_k": 0.00393, "theta_ref_c": 20.0,
           "theta_points_c": 40.0, "ambient_c": 25.0}
LIMIT_C = 40.0


def _model():
    return dataclasses.replace(paper_model(), thermal=dict(THERMAL))


def test_periodic_temperature_matches_the_closed_form():
    """tau theta' = theta_a + r q - theta, q = q0 + A sin(w t): theta = theta_a + r q0
    + r A (sin w t - w tau cos w t) / (1 + (w tau)^2), to 1e-4 K on a 5 s cycle."""
    th = WindingThermal.of(_model(), max_c=100.0)
    period, q0, amp = 5.0, 400.0, 3000.0
    t = np.linspace(0.0, period, 400, endpoint=False)
    w = 2 * np.pi / period
    q = q0 + amp * np.sin(w * t)
    wt = w * th.tau_th_s
    exact = (th.ambient_c + th.r_th_k_per_w * q0
             + th.r_th_k_per_w * amp * (np.sin(w * t) - wt * np.cos(w * t)) / (1 + wt**2))
    got = periodic_temperatures(t, q, period, th, substeps=50)[0]
    assert np.max(np.abs(got - exact)) < 1e-4


def test_without_a_thermal_rating_the_ocp_is_unchanged():
    """No winding limit, or no thermal model: no temperature state, the RMS row stays."""
    opts = OcpOptions(Discretization(n_intervals=8))
    plain = build_ocp(kite_dae(), _model(), opts, system=system_for(_model()))
    assert STATE not in plain.dae.states.names
    hot = system_for(drive={"max_winding_temperature_c": LIMIT_C}).drive
    assert winding_thermal(paper_model(), hot) is None
    line = thermal_line(paper_model(), hot)
    assert "not applied" in line and "no thermal model" in line


#: elec-lim options of the cycles below: 10 intervals
HOT_OPTIONS = OcpOptions(Discretization(n_intervals=10))
#: their drive: the paper's, the winding limited to LIMIT_C, an RMS rating of 60 N m
HOT_DRIVE = {"max_winding_temperature_c": LIMIT_C, "max_speed_rpm": 1500.0,
             "max_torque_nm": 78.0, "nominal_power_w": 8200.0, "continuous_torque_nm": 60.0}


@pytest.fixture(scope="module")
def hot_cycle():
    """elec-lim at 10 m/s, 10 intervals: the problem without the temperature (with an RMS
    rating of 60 N m, the power model without a thermal model) from the stored guess
    interpolated onto 10 intervals, and the winding limited to 40 degC, started from
    that optimum with the thermal part's own start (its cyclic steady temperature)."""
    dae = kite_dae(*load_system().model_params())
    ocp = build_ocp(dae, _model(), HOT_OPTIONS, system=system_for(_model(), drive=HOT_DRIVE))
    scenario = Scenario.of_kind("elec-lim", 10.0)
    plain = build_ocp(dae, paper_model(), HOT_OPTIONS, system=system_for(drive=HOT_DRIVE))
    base = start(plain, scenario)
    hot = solve(ocp, scenario, carry_over(plain, base.warm, ocp, scenario.parameters))
    return ocp, hot, base, plain


def test_the_thermal_limit_binds_and_replaces_the_rms_row(hot_cycle):
    ocp, hot, base, plain = hot_cycle
    assert hot.success and base.success, (hot.status, base.status)
    theta = hot.trajectory[STATE].to_numpy()
    assert theta.max() == pytest.approx(LIMIT_C, abs=1e-3)
    assert "winding_temperature_limit" in hot.active_bounds
    # the summary's figures are the thermal part's, absent without it
    assert hot.figures == {"peak_winding_temperature_c": theta.max(),
                           "thermal_margin_k": LIMIT_C - theta.max()}
    assert base.figures == {}
    assert "rms_torque" not in ocp.layout.rows and "rms_torque" in plain.layout.rows
    # the base (RMS 60 N m, no temperature) flies hotter: the limit changes the optimum
    assert abs(hot.avg_p_elec_w - base.avg_p_elec_w) > 10.0


def test_the_cycle_mean_temperature_is_the_heat_balance(hot_cycle):
    """Over a periodic cycle tau (theta(T) - theta(0)) = 0, so the time mean of theta is
    theta_a + r_th mean(q) exactly (quadrature of the collocation: 1e-3 K)."""
    ocp, hot, _, _ = hot_cycle
    tr, th = hot.trajectory, ocp.formulation.thermal
    heat = tr["p_elec_w"] - tr["p_mech_w"]
    mean_theta = float(np.sum(tr["weight"] * tr[STATE]))
    assert mean_theta == pytest.approx(th.steady_c(float(np.sum(tr["weight"] * heat))),
                                       abs=1e-3)


def _heat_of(ocp, hot):
    """``heat(time, theta_winding)`` [W] of the optimal cycle: the power model at the
    cycle's speed and torque, its copper term at ``theta_winding``, less the shaft power."""
    tr, th, model = hot.trajectory, ocp.formulation.thermal, ocp.drive_model
    t = tr["time_s"].to_numpy()
    period = float(hot.period_s)
    base_heat = model.p_elec_w(tr["speed_rpm"].to_numpy(), tr["torque_nm"].to_numpy()) \
        - tr["p_mech_w"].to_numpy()
    torque = tr["torque_nm"].to_numpy()
    a = th.copper_temp_coeff_per_k

    def heat(time, theta_c):
        tt = np.mod(time, period)
        torq = np.interp(tt, t, torque, period=period)
        return np.interp(tt, t, base_heat, period=period) + th.copper_w_per_nm2 * torq**2 * (
            (1 + a * (theta_c - th.theta_ref_c)) / (1 + a * (th.theta_model_c - th.theta_ref_c))
            - 1)
    return heat


def test_fifty_cycles_forward_stay_on_the_periodic_temperature(hot_cycle):
    """RK45 over 50 repeated cycles from the OCP's theta(0), the heat recomputed at the
    simulated temperature from the cycle's speed, torque and shaft power: ends within
    0.5 K of the OCP's periodic temperature."""
    ocp, hot, _, _ = hot_cycle
    th, heat, period = ocp.formulation.thermal, _heat_of(ocp, hot), float(hot.period_s)

    def rhs(time, y):
        return [(th.ambient_c + th.r_th_k_per_w * heat(time, y[0]) - y[0]) / th.tau_th_s]

    theta_end = hot.trajectory[STATE].to_numpy()[-1]  # the last Radau point is the period's end
    sim = solve_ivp(rhs, (0.0, 50 * period), [theta_end], rtol=1e-9, atol=1e-9,
                    max_step=period / 40)
    assert math.isfinite(sim.y[0, -1])
    assert abs(sim.y[0, -1] - theta_end) < 0.5


#: a two-node network of the same steady resistance (0.05 K/W): the winding 1.5 kJ/K,
#: 0.015 K/W to a 15 kJ/K housing, 0.035 K/W from it to the ambient
LADDER = ((1500.0, 0.015), (15000.0, 0.035))


def test_a_two_node_network_is_periodic_in_the_cycle_and_its_winding_limited(hot_cycle):
    """The same problem with a two-node network, warm-started from the one-node optimum
    (its housing node filled by the thermal part's start): the winding (not the housing)
    reaches the limit, and 50 cycles of an RK45 integration of the node equations
    (C dtheta/dt = heat flows) from the OCP's end temperatures end within 0.5 K of them
    at both nodes."""
    one_node, one, _, _ = hot_cycle
    (c_w, r_wh), (c_h, r_ha) = LADDER
    thermal = {**THERMAL, "nodes": 2, "ladder": [{"node": "winding", "c_j_per_k": c_w,
                                                   "r_k_per_w": r_wh},
                                                  {"node": "housing", "c_j_per_k": c_h,
                                                   "r_k_per_w": r_ha}]}
    model = dataclasses.replace(paper_model(), thermal=thermal)
    ocp = build_ocp(kite_dae(*load_system().model_params()), model, HOT_OPTIONS,
        system=system_for(model, drive=HOT_DRIVE))
    assert ocp.dae.states.names[-2:] == (STATE, "theta_housing_c")
    warm = carry_over(one_node, one.warm, ocp, Scenario.of_kind("elec-lim", 10.0).parameters)
    hot = solve(ocp, Scenario.of_kind("elec-lim", 10.0), warm)
    assert hot.success, hot.status
    winding = hot.trajectory[STATE].to_numpy()
    housing = hot.trajectory["theta_housing_c"].to_numpy()
    assert winding.max() == pytest.approx(LIMIT_C, abs=1e-3)
    assert "winding_temperature_limit" in hot.active_bounds
    assert housing.max() < LIMIT_C - 1.0
    heat, amb, period = _heat_of(ocp, hot), THERMAL["ambient_c"], float(hot.period_s)

    def rhs(time, y):
        between = (y[0] - y[1]) / r_wh
        return [(heat(time, y[0]) - between) / c_w, (between - (y[1] - amb) / r_ha) / c_h]

    end = [winding[-1], housing[-1]]
    sim = solve_ivp(rhs, (0.0, 50 * period), end, rtol=1e-9, atol=1e-9, max_step=period / 40)
    assert np.max(np.abs(sim.y[:, -1] - end)) < 0.5


@pytest.mark.parametrize("line,needle", [
    ("max_winding_temperature_c = 400.0", "max_winding_temperature_c"),
    ("max_winding_temperature_c = 20.0\nambient_temperature_c = 30.0",
     "max_winding_temperature_c"),
    ("ambient_temperature_c = 120.0", "ambient_temperature_c"),
])
def test_an_implausible_thermal_rating_is_refused_naming_the_key(tmp_path, line, needle):
    text = shipped_system_path().read_text(encoding="utf-8")
    path = tmp_path / "system.toml"
    path.write_text(text.replace("[drive]\n", f"[drive]\n{line}\n", 1), encoding="utf-8")
    with pytest.raises(InputError, match=needle):
        load_system(path)


@pytest.mark.parametrize("s", [0.5, 2.0, 3.7])
def test_the_carried_thermal_model_keeps_the_temperature_at_corresponding_points(s):
    """The sizing law: a drive s times the torque reaches, at (n, s T), the base drive's
    steady temperature at (n, T), its copper drift included (s base drives side by side)."""
    base = _model()
    carried = carry_power_model(base, 1.0, s)
    n, torque, theta = np.array([-900.0, 300.0, 1200.0]), np.array([20.0, 55.0, 70.0]), 62.0
    th_b = WindingThermal.of(base, max_c=150.0)
    th_s = WindingThermal.of(carried, max_c=150.0)

    def steady(model, th, speed, tq):
        p_mech = speed * tq / RPM_PER_RAD_S
        return th.steady_c(model.p_elec_w(speed, tq) + th.copper_drift_w(tq, theta) - p_mech)

    assert np.allclose(steady(carried, th_s, n, s * torque), steady(base, th_b, n, torque),
                       rtol=0, atol=1e-9)
    assert th_s.tau_th_s == th_b.tau_th_s and th_s.max_c == th_b.max_c


def test_sizing_by_heat_lists_where_the_winding_limit_binds():
    """candidate_table with the winding limit: the speeds whose cycle reached it, the
    hottest peak, and no RMS column (the RMS row was not in those cycles)."""
    system = load_system()
    rating = drive_in_force(system, drive_model=_model())[0].rating_part()
    cands = scaled_candidates(rating.with_losses(_model()), (1.0, 2.0))
    peaks = {("x1", 5.0): 31.0, ("x1", 9.0): LIMIT_C, ("x2", 5.0): 28.0, ("x2", 9.0): 37.5}
    recs = [{"candidate": c.name, "wind_speed_m_s": w, "success": True,
             "avg_p_elec_w": -500.0 * w, "rms_torque_nm": 1e3,
             "peak_winding_temperature_c": peaks[c.name, w]}
            for c in cands for w in (5.0, 9.0)]
    table, _, _ = candidate_table(cands, recs, Weibull(2.0, 6.2), 0.02, LIMIT_C)
    rows = table.set_index("candidate")
    assert rows.loc["x1", "thermal_bound_active_at"] == "9"
    assert rows.loc["x2", "thermal_bound_active_at"] == ""
    assert rows.loc["x1", "peak_winding_temperature_c"] == LIMIT_C
    assert (rows["rms_bound_active_at"] == "").all()


@pytest.mark.parametrize("stage", ["optimize", "size"])
def test_a_winding_limit_below_the_fitted_ambient_stops_before_solving(tmp_path, capsys,
                                                                        stage):
    """No ambient in the system file: the thermal model's (25 degC) is in force, and a
    20 degC limit under it stops both stages with exit 2 naming the key, nothing written."""
    from drivebench.cli import main
    from fitting.model_file import save_power_model

    model = save_power_model(_model(), tmp_path / "power_model.json")
    text = shipped_system_path().read_text(encoding="utf-8")
    system = tmp_path / "system.toml"
    system.write_text(text.replace("[drive]\n", "[drive]\nmax_winding_temperature_c = 20.0\n",
                                   1), encoding="utf-8")
    args = {"optimize": ["optimize", "--wind-grid", "7", "--scenarios", "elec-lim",
                         "--no-claims"],
            "size": ["size", "--weibull-k", "2", "--mean-speed", "5.5"]}[stage]
    code = main([*args, "--system", str(system), "--drive-model", str(model),
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(system) in err and "max_winding_temperature_c" in err and "25" in err
    assert not (tmp_path / "out").exists()


def test_the_carried_two_node_network_scales_every_node():
    """The sizing law on a two-node block: every ladder and mode resistance / s, every
    capacity x s, so each node's time constant and the steady winding temperature at
    corresponding points (s x the heat) are the base drive's."""
    (c_w, r_wh), (c_h, r_ha) = LADDER
    thermal = {**THERMAL, "nodes": 2,
               "ladder": [{"node": "winding", "c_j_per_k": c_w, "r_k_per_w": r_wh},
                          {"node": "housing", "c_j_per_k": c_h, "r_k_per_w": r_ha}],
               "modes": [{"r_k_per_w": 0.01, "tau_s": 20.0}, {"r_k_per_w": 0.04, "tau_s": 600.0}]}
    base = dataclasses.replace(paper_model(), thermal=thermal)
    s = 2.5
    carried = carry_power_model(base, 1.0, s).thermal
    for a, b in zip(carried.ladder, thermal["ladder"], strict=True):
        assert a.r_k_per_w == pytest.approx(b["r_k_per_w"] / s, rel=1e-12)
        assert a.c_j_per_k == pytest.approx(b["c_j_per_k"] * s, rel=1e-12)
    assert [m.tau_s for m in carried.modes] == [20.0, 600.0]
    th_b = WindingThermal.of(base, max_c=150.0)
    th_s = WindingThermal.of(dataclasses.replace(base, thermal=carried), max_c=150.0)
    assert [t for _, t in th_s.ladder] == pytest.approx([t for _, t in th_b.ladder], rel=1e-12)
    assert th_s.steady_c(s * 800.0) == pytest.approx(th_b.steady_c(800.0), abs=1e-9)
