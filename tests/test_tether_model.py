"""The tether as a rod with mass, its drag over elements, and the ISA air density.

Truths: the rod's kinetic and potential energy as the integral over its elements (a
fine midpoint sum of ``1/2 dm |v(s)|^2`` and ``dm g h(s)``); the rod's force on the kite
in two motions derived by hand from its Lagrangian; the element drag against a
quadrature of the continuous line (scipy) and, in still air, the closed form
``(1/4 - 1/(8 n^2))`` of the midpoint sum (its limit 1/4 is the lumped model's quarter);
the ISA density against the table of the U.S. Standard Atmosphere 1976 (NOAA-S/T 76-1562,
Table I by geometric altitude; ISO 2533 below 11 km).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import quad
from system_fixtures import system_for

from optimize.model.atmosphere import ISA_LAPSE_K_M, air_density
from optimize.model.kite_model import kite_dae
from optimize.model.params import KiteParams, TetherModel, WindModel
from optimize.model.tether import LINE_FORCE, element_drag, rod_energies, rod_residual

MU_KG_M, G_M_S2 = 0.0046, 9.81  # AP2's line (awebox ampyx_ap2_settings.py L18)
R_M = np.array([120.0, 35.0, -160.0])  # NED: 160 m up
V_M_S = np.array([4.0, 25.0, -6.0])


def _vec(x):
    return np.asarray(ca.DM(x)).ravel()


def test_rod_energies_are_the_integral_over_its_elements():
    kinetic, potential = (float(e) for e in rod_energies(ca.DM(R_M), ca.DM(V_M_S), MU_KG_M,
                                                          G_M_S2))
    length = np.linalg.norm(R_M)
    e = R_M / length
    v0 = (V_M_S @ e) * e  # the line's velocity at the winch: the reeling speed along it
    n = 4000
    s = (np.arange(n) + 0.5) / n
    v = v0 + s[:, None] * (V_M_S - v0)
    dm = MU_KG_M * length / n
    assert kinetic == pytest.approx(0.5 * dm * np.sum(v**2), rel=1e-6)
    assert potential == pytest.approx(dm * G_M_S2 * np.sum(s * -R_M[2]), rel=1e-9)


def test_a_line_turning_about_the_winch_pulls_with_half_its_centripetal_force():
    """|r| fixed, v across r, a = -|v|^2/|r| e (a circle about the winch), no gravity:
    by hand, dT/dv = mu L v / 3, dT/dr = mu |v|^2 e / 6, no mass flow, so the residual is
    mu L a / 3 - mu |v|^2 e / 6 = -mu |v|^2 e / 2."""
    length = np.linalg.norm(R_M)
    e = R_M / length
    v = np.cross(e, [0.0, 1.0, 0.0]) * 30.0
    a = -(v @ v) / length * e
    res = _vec(rod_residual(ca.DM(R_M), ca.DM(v), ca.DM(a), MU_KG_M, 0.0))
    np.testing.assert_allclose(res, -MU_KG_M * (v @ v) / 2 * e, rtol=1e-12, atol=1e-12)


def test_a_line_reeled_out_straight_carries_the_mass_flow():
    """v = u e (reel-out at constant speed u with the line), a = 0, no gravity: T = mu L u^2
    / 2, d/dt dT/dv = mu u^2 e, dT/dr = mu u^2 e / 2, mass flow mu u: the residual is
    mu u^2 e (1 - 1/2 - 1) = -mu u^2 e / 2; at rest under gravity it is dV/dr =
    mu g (h e + L (-e_z)) / 2, half the line's weight and its growth along e."""
    length = np.linalg.norm(R_M)
    e = R_M / length
    u = 7.0
    res = _vec(rod_residual(ca.DM(R_M), ca.DM(u * e), ca.DM.zeros(3), MU_KG_M, 0.0))
    np.testing.assert_allclose(res, -MU_KG_M * u**2 / 2 * e, rtol=1e-12, atol=1e-12)
    rest = _vec(rod_residual(ca.DM(R_M), ca.DM.zeros(3), ca.DM.zeros(3), MU_KG_M, G_M_S2))
    weight = MU_KG_M * G_M_S2 * (-R_M[2] * e + length * np.array([0.0, 0.0, -1.0])) / 2
    np.testing.assert_allclose(rest, weight, rtol=1e-12)


@pytest.mark.parametrize("n", [1, 5, 40])
def test_still_air_element_drag_is_the_midpoint_sum_of_the_lumped_quarter(n):
    r, v = np.array([0.0, 0.0, -100.0]), np.array([0.0, 30.0, 0.0])  # line across v
    cd_d, rho = 1.2 * 0.002, 1.2
    force = _vec(element_drag(ca.DM(r), ca.DM(v), lambda p: ca.DM.zeros(3), lambda p: rho,
                              cd_d, n))
    # sum_k s_k^3 / n over midpoints is 1/4 - 1/(8 n^2); 1/4: the lumped model's quarter
    lumped = 0.25 * cd_d * 0.5 * rho * 100.0 * 30.0 * -v
    np.testing.assert_allclose(force, lumped * (1 - 1 / (2 * n**2)), rtol=1e-9)


def test_element_drag_converges_to_the_quadrature_of_the_line():
    """Shear wind, ISA density, a kite moving across and along the line: the midpoint
    sum over 400 elements against scipy's adaptive quadrature of the same continuous
    integrand ``s dF/ds``, per component; 5 elements (awebox's AP2) within 3 %."""
    cd_d = 1.2 * 0.002
    r, v = R_M, V_M_S
    wind = WindModel(power_law_exponent=0.15, origin_altitude_m=0.0)

    def wind_np(p):
        h = -p[2]
        return np.array([10.0 * (max(h, 1e-3) / 100.0) ** 0.15, 0.0, 0.0])

    def rho_np(p):
        return air_density(-p[2], 1.225, G_M_S2, ISA_LAPSE_K_M)

    def integrand(s, i):
        u = wind_np(s * r) - s * v
        speed = np.linalg.norm(u)
        across = np.sqrt(np.linalg.norm(r) ** 2 - (r @ u / speed) ** 2)
        return s * cd_d * 0.5 * rho_np(s * r) * speed * across * u[i]

    truth = np.array([quad(integrand, 0.0, 1.0, args=(i,), epsabs=1e-12)[0] for i in range(3)])

    def drag(n):
        return _vec(element_drag(ca.DM(r), ca.DM(v),
                                 lambda p: ca.vertcat(wind_np(_vec(p))[0], 0, 0),
                                 lambda p: rho_np(_vec(p)), cd_d, n))

    assert wind.power_law_exponent == 0.15
    np.testing.assert_allclose(drag(400), truth, rtol=1e-5, atol=1e-9 * np.abs(truth).max())
    assert np.linalg.norm(drag(5) - truth) <= 0.03 * np.linalg.norm(truth)


@pytest.mark.parametrize("altitude_m, table_kg_m3", [
    (0.0, 1.2250), (500.0, 1.1673), (1000.0, 1.1117), (2000.0, 1.0066), (3000.0, 0.90925),
    (5000.0, 0.73643)])
def test_isa_density_is_the_standard_atmosphere_table(altitude_m, table_kg_m3):
    """The table is by geometric altitude z; the law by geopotential altitude
    H = R z / (R + z), R = 6356766 m (the 1976 standard's Earth radius)."""
    geopotential_m = 6356766.0 * altitude_m / (6356766.0 + altitude_m)
    rho = air_density(geopotential_m, 1.225, 9.80665, ISA_LAPSE_K_M)
    assert rho == pytest.approx(table_kg_m3, rel=5e-5)


def test_constant_atmosphere_is_the_density_itself():
    assert air_density(ca.SX.sym("h"), 1.23, 9.81, 0.0) == 1.23


def test_the_tether_part_joins_only_a_line_with_mass_or_element_drag():
    """The paper's massless lumped line adds no part (its OCP is the paper's, bit for bit);
    a line with mass adds the line's force on the kite, which the kite's Newton rows
    take: at any point the kite's rows with the part are the kite's own (the plain
    model's, unscaled) minus the line's force, and the part's rows are the force
    variables minus the rod's force."""
    from optimize.paper_model import paper_model
    from optimize.problem.ocp import build_ocp
    from optimize.problem.options import Discretization, OcpOptions

    options = OcpOptions(Discretization(4, 2))
    plain = build_ocp(kite_dae(), paper_model(), options, system=system_for())
    assert "tether" not in [p.name for p in plain.formulation.parts]
    heavy = build_ocp(kite_dae(KiteParams(), None, WindModel(), TetherModel(mass_kg_m=0.01)),
                      paper_model(), options, system=system_for())
    part = [p for p in heavy.formulation.parts if p.name == "tether"]
    assert len(part) == 1 and part[0].algebraic.names == LINE_FORCE
    dae = heavy.dae
    rng = np.random.default_rng(1)
    x, u = rng.normal(size=dae.states.size), rng.normal(size=dae.controls.size)
    z, fict = rng.normal(size=dae.algebraic.size), np.zeros(dae.fictitious.size)
    x[dae.states.indices(("r_x_m", "r_y_m", "r_z_m"))] = R_M
    res = np.asarray(dae.alg(x, u, z, 10.0, fict)).ravel()
    alone = np.asarray(plain.dae.alg(x[:plain.dae.states.size], u, z[:7], 10.0, fict)).ravel()
    force = z[dae.algebraic.indices(LINE_FORCE)]
    scale = heavy.formulation.parts[0].scales_of.residual
    np.testing.assert_allclose(res[:7] * scale, alone - np.r_[force, np.zeros(4)],
                               rtol=1e-9, atol=1e-9)
    rod = _vec(-rod_residual(ca.DM(R_M), ca.DM(x[3:6]), ca.DM(z[:3]), 0.01, 9.81))
    np.testing.assert_allclose(res[7:] * part[0].force_scale_n, force - rod, rtol=1e-9,
                               atol=1e-9)
