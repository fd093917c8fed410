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


def force_coefficients(
    alpha: Any, beta: Any, surfaces_rad: Any, coeffs: AeroCoefficients
) -> tuple[Any, Any, Any]:
    """Lift, drag (wing only) and side-force coefficients [-].

    ``surfaces_rad`` is ``[aileron, elevator, rudder]`` [rad].
    """
    c = coeffs
    ail, elev, rud = surfaces_rad[0], surfaces_rad[1], surfaces_rad[2]
    cl = c.cl0 + c.cl_alpha * alpha + c.cl_elev * elev
    cd = (
        c.cd0
        + c.cd_alpha * alpha
        + c.cd_alpha2 * alpha**2
        + c.cd_beta2 * beta**2
        + c.cd_elev2 * elev**2
        + c.cd_alpha_elev * alpha * elev
        + c.cd_elev * elev
        + c.cd_ail2 * ail**2
        + c.cd_beta_ail * beta * ail
        + c.cd_rud2 * rud**2
        + c.cd_beta_rud * beta * rud
    )
    cy = c.cy_beta * beta + c.cy_rud * rud
    return cl, cd, cy


def moment_coefficients(
    alpha: Any,
    beta: Any,
    omega_hat: Any,
    surfaces_rad: Any,
    coeffs: AeroCoefficients,
) -> tuple[Any, Any, Any]:
    """Roll, pitch and yaw moment coefficients [-].

    ``omega_hat`` is ``[p b/(2v), q c/(2v), r b/(2v)]`` [-].
    """
    c = coeffs
    p, q, r = omega_hat[0], omega_hat[1], omega_hat[2]
    ail, elev, rud = surfaces_rad[0], surfaces_rad[1], surfaces_rad[2]
    c_roll = (
        c.cl_p * p + c.cl_r * r + c.cl_beta * beta + c.cl_alpha_beta * alpha * beta
        + c.cl_ail * ail
    )
    c_pitch = c.cm0 + c.cm_q * q + c.cm_alpha * alpha + c.cm_elev * elev
    c_yaw = (
        c.cn_p * p + c.cn_r * r + c.cn_beta * beta + c.cn_alpha_beta * alpha * beta
        + c.cn_rud * rud
    )
    return c_roll, c_pitch, c_yaw


def aero_forces_moments(
    dcm: Any,
    v_air_world: Any,
    omega_body: Any,
    surfaces_rad: Any,
    tether_length_m: Any,
    kite: KiteParams,
    coeffs: AeroCoefficients,
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
    """
    v_air_body = ca.mtimes(dcm.T, v_air_world)
    airspeed, alpha, beta = aero_angles(v_air_body)
    cl, cd_wing, cy = force_coefficients(alpha, beta, surfaces_rad, coeffs)
    cd = cd_wing + kite.tether_cd_per_m * tether_length_m / kite.sref_m2
    half_rho_s = 0.5 * kite.rho_kg_m3 * kite.sref_m2
    e_y = dcm[:, 1]
    lift_dir_v = ca.cross(e_y, v_air_world)  # |.| = airspeed when v _|_ e_y
    side_dir_v2 = ca.cross(lift_dir_v, -v_air_world)
    force = half_rho_s * (
        airspeed * cl * lift_dir_v - airspeed * cd * v_air_world + cy * side_dir_v2
    )
    scale = ca.vertcat(kite.bref_m, kite.cref_m, kite.bref_m)
    omega_hat = scale * omega_body / (2.0 * airspeed)
    c_roll, c_pitch, c_yaw = moment_coefficients(alpha, beta, omega_hat, surfaces_rad, coeffs)
    q_s = half_rho_s * airspeed**2
    moment = ca.vertcat(
        q_s * kite.bref_m * c_roll, q_s * kite.cref_m * c_pitch, q_s * kite.bref_m * c_yaw
    )
    return AeroOutput(force, moment, airspeed, alpha, beta, cl, cd, cy)
