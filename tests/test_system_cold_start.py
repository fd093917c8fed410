"""A cold start (homotopy, no stored guess) of a shipped non-default system: the AP2-size wing.

The start loop, the scales and the bounds all come from ``ap2.toml``; the drive is
the paper's design carried to the file's rating by the similarity law. Checked against
independent truths: the solver converged without sitting on a bound the file did not mean
to bind, the path stays inside the file's bounds, and the mechanical power generated is positive
but below Loyd's crosswind limit for the wing's best lift-to-drag ratio at the
strongest wind the cycle meets.
"""

from __future__ import annotations

import numpy as np
import pytest

from optimize.model.aero import force_coefficients
from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.problem.scenario import Scenario
from optimize.solve.starts.homotopy import solve_by_homotopy
from optimize.sweep.outputs import MEANT_BOUNDS
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system

WIND_M_S = 7.0


@pytest.fixture(scope="module")
def solved():
    system = load_system(shipped_system_path("ap2"))
    drive, _ = drive_in_force(system)  # the paper's drive carried to the AP2 rating
    model = drive.power_model
    options = OcpOptions(Discretization(n_intervals=20, degree=3),
                         solver=SolverOptions(stored_guess=False))
    ocp = build_ocp(kite_dae(*system.model_params()), model, options,
                    system=system.in_force(drive))
    return system, ocp, solve_by_homotopy(ocp, Scenario(WIND_M_S, "mechanical", True))


def test_cold_start_of_the_ap2_system_converges_off_unmeant_bounds(solved):
    system, ocp, res = solved
    assert res.success, res.status
    assert [s["stage"] for s in res.stages][0] == "track"
    assert not [b for b in res.active_bounds if b not in MEANT_BOUNDS], res.active_bounds
    b = system.bounds
    traj = res.trajectory
    assert b.period_min_s < res.period_s < b.period_max_s
    assert traj["l_m"].between(b.tether_length_min_m, b.tether_length_max_m).all()
    # the ground clearance is at least half the span (issue 11 §3); 1 mm solver slack
    assert traj["altitude_m"].min() >= system.ground_clearance_m() - 1e-3
    assert system.ground_clearance_m() >= 0.5 * system.kite.span_m
    assert traj["tension_n"].min() >= -1e-6
    assert res.max_violation < 1e-5


def test_generated_power_is_below_loyds_limit(solved):
    # Loyd (1980): a crosswind kite generates at most (2/27) rho S w^3 C_L (C_L/C_D)^2;
    # with the best C_L^3/C_D^2 in the valid alpha range (tether drag at the shortest
    # length) and the strongest wind of the cycle this bounds the cycle average.
    system, ocp, res = solved
    c, k = system.aero_coefficients(), system.kite_params()
    alpha = np.radians(np.linspace(system.aero.alpha_min_deg, system.aero.alpha_max_deg, 200))
    cl, cd, _ = force_coefficients(alpha, 0.0, (0.0, 0.0, 0.0), c)
    l_min = res.trajectory["l_m"].min()
    cd = cd + k.tether_cd_per_m * l_min / k.sref_m2  # 0 with the tether's element drag
    ok = cl > 0
    w_max = res.trajectory["wind_m_s"].max()
    loyd = 2 / 27 * k.rho_kg_m3 * k.sref_m2 * w_max**3 * np.max(cl[ok] ** 3 / cd[ok] ** 2)
    generated = -res.avg_p_mech_w
    assert 0 < generated < loyd, (generated, loyd)
