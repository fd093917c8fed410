"""Aerodynamic forces and moments of the rigid-wing kite (docs/paper_figures.md §2, paper app. B).

Pure functions of CasADi expressions (``SX``/``MX``) or numbers (``DM``). Frames:
world NED (wind along +x), body x forward, y right wing, z down. ``R`` maps body
to world coordinates (its columns are the body axes in the world frame).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca

from optimize.model.params import AeroCoefficients, KiteParams, WindModel

#: the control surfaces, in the order of every per-surface tuple (``surfaces_rad``, bounds)
SURFACES = ("aileron", "elevator", "rudder")


def wind_speed(altitude_m: Any, wind_speed_m_s: Any, wind: WindModel) -> Any:
    """Wind speed [m/s] at ``altitude_m`` above ground [m] (log law, or power law)."""
    if wind.power_law_exponent > 0:
        ratio = ca.fmax(altitude_m, 1e-3) / wind.reference_altitude_m
        return wind_speed_m_s * ratio**wind.power_law_exponent
    z0 = wind.roughness_length_m
    return (
        wind_speed_m_s
        * ca.log((altitude_m + z0) / z0)
        / ca.log(wind.reference_altitude_m / z0)
    )


def altitude_above_ground(position_m: Any, wind: WindModel) -> Any:
    """Altitude above ground [m] of a world (NED) position [m]."""
    return -position_m[2] + wind.origin_altitude_m


def aero_angles(v_air_body: Any) -> tuple[Any, Any, Any]:
    """Airspeed [m/s], angle of attack and sideslip [rad] of the air-relative velocity.

    Parameters
    ----------
    v_air_body : 3-vector
        Kite velocity relative to the air, body axes [m/s].
    """
    airspeed = ca.norm_2(v_air_body)
    alpha = ca.atan2(v_air_body[2], v_air_body[0])
    beta = ca.asin(v_air_body[1] / airspeed)
    return airspeed, alpha, beta


@dataclass(frozen=True)
class AeroOutput:
    """Aerodynamic force (world frame) [N], moment (body frame) [N m] and diagnostics."""

    force_n: Any
    moment_nm: Any
    airspeed_m_s: Any
    alpha_rad: Any
    beta_rad: Any
    cl: Any
    cd: Any
    cy: Any


def at_alpha(coefficient: Any, alpha: Any) -> Any:
    """A coefficient at angle of attack ``alpha`` [rad]: the number itself, or the
    polynomial ``c0 + c1 alpha + c2 alpha^2 + ...`` of a tuple (Horner's scheme)."""
    if not isinstance(coefficient, tuple):
        return coefficient
    value = coefficient[-1]
    for c in reversed(coefficient[:-1]):
        value = value * alpha + c
    return value


def _given(coefficient: Any) -> bool:
    """Whether an optional coefficient (number or polynomial) is not zero."""
    return any(coefficient) if isinstance(coefficient, tuple) else coefficient != 0


def _plus(total: Any, alpha: Any, pairs: tuple) -> Any:
    """``total + sum c(alpha) * x`` over the ``(coefficient, x)`` pairs whose coefficient
    is given (an absent one leaves its term out of the expression)."""
    for coefficient, x in pairs:
        if _given(coefficient):
            total = total + at_alpha(coefficient, alpha) * x
    return total


def force_coefficients(
    alpha: Any, beta: Any, surfaces_rad: Any, coeffs: AeroCoefficients, omega_hat: Any = None
) -> tuple[Any, Any, Any]:
    """Lift, drag (wing only) and side-force coefficients [-].

    ``surfaces_rad`` is ``[aileron, elevator, rudder]`` [rad]; ``omega_hat`` the
    normalized rates ``[p b/(2v), q c/(2v), r b/(2v)]`` [-] of the rate derivatives
    (``cl_q``, ``cd_q``, ``cy_p``, ``cy_r``; ``None``: left out). Every coefficient
    may be a polynomial in ``alpha`` (:func:`at_alpha`).
    """
    c = coeffs

    def k(coefficient: Any) -> Any:
        return at_alpha(coefficient, alpha)

    ail, elev, rud = surfaces_rad[0], surfaces_rad[1], surfaces_rad[2]
    cl = k(c.cl0) + k(c.cl_alpha) * alpha + k(c.cl_elev) * elev
    cd = (
        k(c.cd0)
        + k(c.cd_alpha) * alpha
        + k(c.cd_alpha2) * alpha**2
        + k(c.cd_beta2) * beta**2
        + k(c.cd_elev2) * elev**2
        + k(c.cd_alpha_elev) * alpha * elev
        + k(c.cd_elev) * elev
        + k(c.cd_ail2) * ail**2
        + k(c.cd_beta_ail) * beta * ail
        + k(c.cd_rud2) * rud**2
        + k(c.cd_beta_rud) * beta * rud
    )
    cy = _plus(k(c.cy_beta) * beta + k(c.cy_rud) * rud, alpha, ((c.cy_ail, ail),))
    if omega_hat is not None:
        cl = _plus(cl, alpha, ((c.cl_q, omega_hat[1]),))
        cd = _plus(cd, alpha, ((c.cd_q, omega_hat[1]),))
        cy = _plus(cy, alpha, ((c.cy_p, omega_hat[0]), (c.cy_r, omega_hat[2])))
    return cl, cd, cy


def moment_coefficients(
    alpha: Any,
    beta: Any,
    omega_hat: Any,
    surfaces_rad: Any,
    coeffs: AeroCoefficients,
) -> tuple[Any, Any, Any]:
    """Roll, pitch and yaw moment coefficients [-].

    ``omega_hat`` is ``[p b/(2v), q c/(2v), r b/(2v)]`` [-]; every coefficient may be
    a polynomial in ``alpha`` (:func:`at_alpha`).
    """
    c = coeffs

    def k(coefficient: Any) -> Any:
        return at_alpha(coefficient, alpha)

    p, q, r = omega_hat[0], omega_hat[1], omega_hat[2]
    ail, elev, rud = surfaces_rad[0], surfaces_rad[1], surfaces_rad[2]
    c_roll = _plus(
        k(c.cl_p) * p + k(c.cl_r) * r + k(c.cl_beta) * beta
        + k(c.cl_alpha_beta) * alpha * beta + k(c.cl_ail) * ail, alpha, ((c.cl_rud, rud),))
    c_pitch = k(c.cm0) + k(c.cm_q) * q + k(c.cm_alpha) * alpha + k(c.cm_elev) * elev
    c_yaw = _plus(
        k(c.cn_p) * p + k(c.cn_r) * r + k(c.cn_beta) * beta
        + k(c.cn_alpha_beta) * alpha * beta + k(c.cn_rud) * rud, alpha, ((c.cn_ail, ail),))
    return c_roll, c_pitch, c_yaw


def aero_forces_moments(
    dcm: Any,
    v_air_world: Any,
    omega_body: Any,
    surfaces_rad: Any,
    tether_length_m: Any,
    kite: KiteParams,
    coeffs: AeroCoefficients,
    rho_kg_m3: Any = None,
) -> AeroOutput:
    """Aerodynamic force and moment on the kite (paper appendix B).

    Lift acts along ``e_y x v``, drag against ``v``, side force along
    ``(e_y x v) x (-v)`` (so a positive sideslip gives a restoring force with
    ``cy_beta < 0``, as in the reference implementation). The tether drag
    adds ``tether_cd_per_m * l / sref`` to the drag coefficient.

    Parameters
    ----------
    dcm : 3x3
        Body-to-world rotation matrix [-].
    v_air_world : 3-vector
        Kite velocity relative to the air, world frame [m/s].
    omega_body : 3-vector
        Angular velocity in body axes [rad/s].
    surfaces_rad : 3-vector
        Aileron, elevator, rudder deflections [rad].
    tether_length_m : scalar
        Tether length [m].
    rho_kg_m3 : scalar, optional
        Air density at the kite [kg/m^3] (:mod:`optimize.model.atmosphere`); default
        ``kite.rho_kg_m3``.
    """
    v_air_body = ca.mtimes(dcm.T, v_air_world)
    airspeed, alpha, beta = aero_angles(v_air_body)
    scale = ca.vertcat(kite.bref_m, kite.cref_m, kite.bref_m)
    omega_hat = scale * omega_body / (2.0 * airspeed)
    cl, cd_wing, cy = force_coefficients(alpha, beta, surfaces_rad, coeffs, omega_hat)
    cd = cd_wing + kite.tether_cd_per_m * tether_length_m / kite.sref_m2
    rho = kite.rho_kg_m3 if rho_kg_m3 is None else rho_kg_m3
    half_rho_s = 0.5 * rho * kite.sref_m2
    e_y = dcm[:, 1]
    lift_dir_v = ca.cross(e_y, v_air_world)  # |.| = airspeed when v _|_ e_y
    side_dir_v2 = ca.cross(lift_dir_v, -v_air_world)
    force = half_rho_s * (
        airspeed * cl * lift_dir_v - airspeed * cd * v_air_world + cy * side_dir_v2
    )
    c_roll, c_pitch, c_yaw = moment_coefficients(alpha, beta, omega_hat, surfaces_rad, coeffs)
    q_s = half_rho_s * airspeed**2
    moment = ca.vertcat(
        q_s * kite.bref_m * c_roll, q_s * kite.cref_m * c_pitch, q_s * kite.bref_m * c_yaw
    )
    return AeroOutput(force, moment, airspeed, alpha, beta, cl, cd, cy)
