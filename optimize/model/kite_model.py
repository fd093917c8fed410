"""Tethered rigid-wing kite DAE in non-minimal coordinates (paper eqs. 6-8).

Parameters and conventions: docs/paper_figures.md §2.

States ``x`` (24): position ``r`` [m] and velocity ``v`` [m/s] of the CG in the
world NED frame, the body-to-world DCM ``R`` (9 entries, column-major), body
angular velocity ``omega`` [rad/s], tether length ``l`` [m] and its first two
derivatives, and the aileron/elevator/rudder deflections [rad].
Controls ``u`` (4): tether jerk ``dddl`` [m/s^3] and surface rates [rad/s].
Algebraic ``z`` (7): CG acceleration ``a`` [m/s^2], angular acceleration
``domega`` [rad/s^2] and the tether multiplier ``nu`` [N/m] of the constraint
``c = (|r + R [0,0,zt]|^2 - l^2)/2 = 0``; tether tension is ``l * nu``.

The dynamics are implicit (mass-matrix form): the explicit part is
``xdot = f(x, u, z)`` (kinematics) and the algebraic residual ``g(x, z, ...)``
states Newton-Euler with the tether multiplier and ``d2c/dt2 = 0``. The
algebraic residual also takes fictitious forces/moments, used only by the
initialization homotopy (zero in the physical model).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from kernel.names import WIND_SPEED
from optimize.model.aero import aero_forces_moments, altitude_above_ground, wind_speed
from optimize.model.atmosphere import air_density
from optimize.model.params import AeroCoefficients, KiteParams, TetherModel, WindModel
from optimize.model.variables import Variables

#: states: CG position and velocity (NED), body-to-world DCM (column-major), body
#: angular velocity, tether length and its two rates, control-surface deflections
STATES = Variables(
    ("r_x_m", "r_y_m", "r_z_m", "v_x_m_s", "v_y_m_s", "v_z_m_s")
    + tuple(f"dcm_{i}{j}" for j in (1, 2, 3) for i in (1, 2, 3))
    + ("omega_x_rad_s", "omega_y_rad_s", "omega_z_rad_s")
    + ("l_m", "dl_m_s", "ddl_m_s2", "aileron_rad", "elevator_rad", "rudder_rad")
)
#: controls: tether jerk and control-surface rates
CONTROLS = Variables(("dddl_m_s3", "daileron_rad_s", "delevator_rad_s", "drudder_rad_s"))
#: algebraic variables: CG acceleration, angular acceleration, tether multiplier
ALGEBRAIC = Variables(("a_x_m_s2", "a_y_m_s2", "a_z_m_s2", "domega_x_rad_s2",
                       "domega_y_rad_s2", "domega_z_rad_s2", "nu_n_per_m"))
#: the model's parameter: the wind speed at the reference height
PARAMETERS = Variables((WIND_SPEED,))
#: fictitious forces and moments of the initialization homotopy
FICTITIOUS = Variables(("f_fict_x_n", "f_fict_y_n", "f_fict_z_n", "m_fict_x_nm",
                        "m_fict_y_nm", "m_fict_z_nm"))
#: the state components that repeat over a cycle (the DCM closes through its relative
#: rotation, the downwind position and velocity are free to differ)
PERIODIC_STATES = (
    "r_y_m", "r_z_m", "v_y_m_s", "v_z_m_s", "omega_x_rad_s", "omega_y_rad_s",
    "omega_z_rad_s", "l_m", "dl_m_s", "ddl_m_s2", "aileron_rad", "elevator_rad", "rudder_rad",
)


def _skew(w: ca.SX) -> ca.SX:
    return ca.vertcat(
        ca.horzcat(0, -w[2], w[1]), ca.horzcat(w[2], 0, -w[0]), ca.horzcat(-w[1], w[0], 0)
    )


@dataclass(frozen=True)
class KiteDae:
    """CasADi functions of the kite DAE (all SX, evaluable numerically or symbolically).

    Implements :class:`optimize.model.dae.Dae`.

    Attributes
    ----------
    states, controls, algebraic, fictitious, parameters : Variables
        The named components of ``x``, ``u``, ``z``, the fictitious forces and the
        parameters (:data:`STATES`, :data:`CONTROLS`, :data:`ALGEBRAIC`,
        :data:`FICTITIOUS`, :data:`PARAMETERS`).
    periodic : tuple of str
        The states that repeat over a cycle (:data:`PERIODIC_STATES`).
    ode : Function
        ``(x, u, z) -> xdot``: kinematics, explicit in the algebraic variables.
    alg : Function
        ``(x, u, z, wind_speed_m_s, fict) -> residual (7)``: Newton-Euler rows
        [N], [N m] and ``d2c/dt2`` [m^2/s^2]; zero on the physical solution.
    outputs : Function
        ``(x, u, z, wind_speed_m_s) -> dict`` of named scalar outputs (airspeed,
        angles, tension, line angle cosine, altitude, invariants, ...).
    invariants : Function
        ``x -> (c [m^2], dc/dt [m^2/s], R^T R - I (3x3))``.
    explicit_ode : Function
        ``(x, u, wind_speed_m_s) -> xdot`` with ``z`` solved from ``alg`` (for simulation).
    solve_z : Function
        ``(x, u, wind_speed_m_s) -> z`` (the physical algebraic variables).
    """

    kite: KiteParams
    coeffs: AeroCoefficients
    wind: WindModel
    ode: ca.Function
    alg: ca.Function
    outputs: ca.Function
    invariants: ca.Function
    explicit_ode: ca.Function
    solve_z: ca.Function
    states: Variables = STATES
    controls: Variables = CONTROLS
    algebraic: Variables = ALGEBRAIC
    fictitious: Variables = FICTITIOUS
    parameters: Variables = PARAMETERS
    periodic: tuple[str, ...] = PERIODIC_STATES
    tether: TetherModel = TetherModel()


def _split_state(x):
    r, v = x[0:3], x[3:6]
    dcm = ca.reshape(x[6:15], 3, 3)
    omega = x[15:18]
    l, dl, ddl = x[18], x[19], x[20]
    surf = x[21:24]
    return r, v, dcm, omega, l, dl, ddl, surf


def _tether_constraint(r, v, acc, dcm, omega, domega, l, dl, ddl, kite: KiteParams):
    """The tether constraint ``c = (|r_bridle|^2 - l^2)/2`` and its two time derivatives,
    with the bridle point ``r_bridle`` [m]."""
    zt_b = ca.DM([0.0, 0.0, kite.zt_m])
    r_bridle = r + ca.mtimes(dcm, zt_b)
    v_bridle = v + ca.mtimes(dcm, ca.cross(omega, zt_b))
    a_bridle = acc + ca.mtimes(dcm, ca.cross(domega, zt_b) + ca.cross(omega, ca.cross(omega, zt_b)))
    c = 0.5 * (ca.dot(r_bridle, r_bridle) - l**2)
    cdot = ca.dot(r_bridle, v_bridle) - l * dl
    cddot = ca.dot(v_bridle, v_bridle) + ca.dot(r_bridle, a_bridle) - dl**2 - l * ddl
    return c, cdot, cddot, r_bridle


def _newton_euler(r, r_bridle, dcm, omega, acc, domega, nu, fict, aero, kite: KiteParams):
    """Force [N] and moment [N m] residuals of the rigid wing on its tether (paper eq. 8)."""
    zt_b = ca.DM([0.0, 0.0, kite.zt_m])
    jmat = ca.DM(
        [
            [kite.j1_kg_m2, 0, kite.j31_kg_m2],
            [0, kite.j2_kg_m2, 0],
            [kite.j31_kg_m2, 0, kite.j3_kg_m2],
        ]
    )
    gravity = ca.vertcat(0, 0, kite.mass_kg * kite.g_m_s2)
    # Newton: m a = F_aero + m g e_z - nu * r_bridle (+ fictitious force)
    res_force = kite.mass_kg * acc + nu * r_bridle - aero.force_n - gravity - fict[0:3]
    # Euler: J domega + omega x J omega = M_aero - nu * zt x (R^T r) (+ fictitious moment)
    res_moment = (
        ca.mtimes(jmat, domega)
        + ca.cross(omega, ca.mtimes(jmat, omega))
        + nu * ca.cross(zt_b, ca.mtimes(dcm.T, r))
        - aero.moment_nm
        - fict[3:6]
    )
    return res_force, res_moment


def kite_dae(
    kite: KiteParams | None = None,
    coeffs: AeroCoefficients | None = None,
    wind: WindModel | None = None,
    tether: TetherModel | None = None,
) -> KiteDae:
    """Build the kite DAE functions (paper eqs. 6-8 with the aero model of app. B, the air
    density of :mod:`optimize.model.atmosphere`). ``tether`` is carried along: its mass
    and element drag enter the OCP as a part of their own
    (:class:`optimize.problem.tether_part.TetherPart`), the line's force on the kite."""
    kite = kite or KiteParams()
    coeffs = coeffs or AeroCoefficients()
    wind = wind or WindModel()
    tether = tether or TetherModel()
    x = ca.SX.sym("x", STATES.size)
    u = ca.SX.sym("u", CONTROLS.size)
    z = ca.SX.sym("z", ALGEBRAIC.size)
    wind_speed_m_s = ca.SX.sym(WIND_SPEED)
    fict = ca.SX.sym("fict", FICTITIOUS.size)
    r, v, dcm, omega, l, dl, ddl, surf = _split_state(x)
    acc, domega, nu = z[0:3], z[3:6], z[6]

    # kinematics: rdot = v, vdot = a, Rdot = R [omega]x, omega_dot = domega (paper eq. 7)
    xdot = ca.vertcat(
        v, acc, ca.reshape(ca.mtimes(dcm, _skew(omega)), 9, 1), domega, dl, ddl, u[0], u[1:4]
    )
    c, cdot, cddot, r_bridle = _tether_constraint(r, v, acc, dcm, omega, domega, l, dl, ddl,
                                                  kite)
    altitude = altitude_above_ground(r, wind)
    w_local = wind_speed(altitude, wind_speed_m_s, wind)
    v_air = v - ca.vertcat(w_local, 0, 0)
    rho = air_density(altitude, kite.rho_kg_m3, kite.g_m_s2, wind.temperature_lapse_k_m)
    aero = aero_forces_moments(dcm, v_air, omega, surf, l, kite, coeffs, rho)
    res_force, res_moment = _newton_euler(r, r_bridle, dcm, omega, acc, domega, nu, fict, aero,
                                          kite)
    residual = ca.vertcat(res_force, res_moment, cddot)

    outputs = {
        "airspeed_m_s": aero.airspeed_m_s,
        "alpha_rad": aero.alpha_rad,
        "beta_rad": aero.beta_rad,
        "tension_n": l * nu,
        "cos_line_angle": -ca.dot(dcm[:, 2], r) / ca.norm_2(r),
        "altitude_m": altitude,
        "wind_m_s": w_local,
        "cl": aero.cl,
        "cd": aero.cd,
        "c_m2": c,
        "cdot_m2_s": cdot,
    }

    # The residual is affine in z: z = -A^{-1} residual(z=0) with A = d residual / dz.
    jac = ca.jacobian(residual, z)
    res0 = ca.substitute(residual, ca.vertcat(z, fict),
                         ca.DM.zeros(ALGEBRAIC.size + FICTITIOUS.size))
    jac0 = ca.substitute(jac, fict, ca.DM.zeros(FICTITIOUS.size))
    z_phys = -ca.solve(jac0, res0)
    xdot_phys = ca.substitute(xdot, z, z_phys)

    orth = ca.mtimes(dcm.T, dcm) - ca.DM.eye(3)
    return KiteDae(
        kite=kite,
        coeffs=coeffs,
        wind=wind,
        ode=ca.Function("kite_ode", [x, u, z], [xdot], ["x", "u", "z"], ["xdot"]),
        alg=ca.Function("kite_alg", [x, u, z, wind_speed_m_s, fict], [residual]),
        outputs=ca.Function(
            "kite_outputs", [x, u, z, wind_speed_m_s], list(outputs.values()),
            ["x", "u", "z", WIND_SPEED], list(outputs.keys()),
        ),
        invariants=ca.Function("kite_invariants", [x], [c, cdot, orth]),
        explicit_ode=ca.Function("kite_explicit_ode", [x, u, wind_speed_m_s], [xdot_phys]),
        solve_z=ca.Function("kite_solve_z", [x, u, wind_speed_m_s], [z_phys]),
        tether=tether,
    )
