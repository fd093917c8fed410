"""Circular-loop initial guess for the pumping-cycle OCP (no stored solution needed).

The kite flies a circle of constant speed on a cone around a downwind axis at
constant tether length. Its body z axis points along the tether towards the
winch and its x axis along the flight path, so the whole configuration
rotates rigidly about the cone axis: positions, velocities, accelerations,
attitude and angular velocity are exact, and the invariants ``c`` and
``dc/dt`` are zero. The guess is not a solution of the physical dynamics; the
fictitious forces and moments that would make it one are returned as well
(the homotopy starts from them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optimize.model.aero import force_coefficients
from optimize.model.kite_model import KiteDae
from optimize.model.params import AeroCoefficients, KiteParams, WindModel

#: sine of the bank angle whose lift turns the start loop (53 deg)
LOOP_SIN_BANK = 0.8
#: start loop speed in units of the speed at which lift at the largest valid angle of
#: attack carries the weight (lift about 4 times the weight in the loop)
LOOP_SPEED_FACTOR = 2.0
#: cone half angle and lowest cone-axis elevation of the start loop [deg]
LOOP_CONE_DEG, LOOP_ELEVATION_DEG = 15.0, 30.0


@dataclass(frozen=True)
class LoopGuess:
    """Geometry of the circular guess.

    Parameters
    ----------
    period_s : float
        Time for one loop [s].
    tether_length_m : float
        Constant tether length [m].
    elevation_deg : float
        Elevation of the cone axis above the horizon, downwind [deg].
    cone_half_angle_deg : float
        Half opening angle of the cone [deg] (loop radius = l sin of it).
    pitch_deg : float
        Body pitch about its y axis relative to the flight path [deg]
        (positive = nose up); lowers the angle of attack of the guess.
    """

    period_s: float = 5.0
    tether_length_m: float = 80.0
    elevation_deg: float = 30.0
    cone_half_angle_deg: float = 15.0
    pitch_deg: float = -7.0


def start_loop(
    kite: KiteParams,
    coeffs: AeroCoefficients,
    wind: WindModel,
    alpha_max_deg: float,
    min_airspeed_m_s: float,
    period_bounds_s: tuple[float, float],
    tether_bounds_m: tuple[float, float],
    min_altitude_m: float,
) -> LoopGuess:
    """The circular start loop of a system, inside its bounds.

    The loop radius is the turn radius ``2 (m/S) / (rho C_L sin(phi))`` at the lift
    coefficient of the largest valid angle of attack and a bank ``phi`` with
    ``sin(phi)`` = :data:`LOOP_SIN_BANK`; the cone half angle is kept at
    :data:`LOOP_CONE_DEG`, so the tether length follows the radius. The speed is
    :data:`LOOP_SPEED_FACTOR` times the speed at which that lift carries the weight
    (at least 1.5 times the minimum airspeed); the period is one turn at that speed.
    The tether length and the period are clamped inside their bounds, and the cone
    axis is raised until the loop's lowest point is half a radius above the
    lowest allowed altitude.

    Parameters
    ----------
    kite, coeffs, wind
        The system.
    alpha_max_deg : float
        Largest valid angle of attack [deg].
    min_airspeed_m_s : float
        Lower airspeed bound [m/s].
    period_bounds_s, tether_bounds_m : (float, float)
        Period [s] and tether length [m] bounds.
    min_altitude_m : float
        Lowest allowed CG altitude above ground [m].
    """
    cl = force_coefficients(math.radians(alpha_max_deg), 0.0, (0.0, 0.0, 0.0), coeffs)[0]
    loading = kite.mass_kg / kite.sref_m2
    cone = math.radians(LOOP_CONE_DEG)
    radius = 2.0 * loading / (kite.rho_kg_m3 * cl * LOOP_SIN_BANK)
    length = radius / math.sin(cone)
    lo, hi = tether_bounds_m
    length = min(max(length, 1.2 * lo), 0.8 * hi)
    radius = length * math.sin(cone)
    speed = max(LOOP_SPEED_FACTOR * math.sqrt(2.0 * kite.g_m_s2 * loading / (kite.rho_kg_m3 * cl)),
                1.5 * min_airspeed_m_s)
    t_lo, t_hi = period_bounds_s
    period = min(max(2.0 * math.pi * radius / speed, t_lo * 1.1), t_hi / 1.1)
    lowest = min_altitude_m - wind.origin_altitude_m + 0.5 * radius
    elevation = max(math.radians(LOOP_ELEVATION_DEG),
                    cone + math.asin(min(max(lowest / length, 0.0), 0.9)))
    return LoopGuess(period_s=period, tether_length_m=length,
                     elevation_deg=math.degrees(elevation), cone_half_angle_deg=LOOP_CONE_DEG)


def circular_loop(
    dae: KiteDae, guess: LoopGuess, times_s: np.ndarray, wind_speed_m_s: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States, algebraic variables and fictitious forces of the loop at ``times_s``.

    Returns
    -------
    x : ndarray (NX, n)
        States [SI] (surfaces and tether rates zero).
    z : ndarray (NZ, n)
        Exact accelerations, zero angular acceleration, and the tether
        multiplier [N/m] that best balances the force residual (least squares).
    fict : ndarray (NF, n)
        Fictitious forces [N] and moments [N m] that make the algebraic
        residual exactly zero.
    """
    eps = np.radians(guess.elevation_deg)
    theta = np.radians(guess.cone_half_angle_deg)
    rho = guess.tether_length_m  # CG distance from the winch
    pitch = np.radians(guess.pitch_deg)
    # body pitch rotation (nose up for pitch > 0) about the body y axis
    rot_pitch = np.array(
        [[np.cos(pitch), 0, np.sin(pitch)], [0, 1, 0], [-np.sin(pitch), 0, np.cos(pitch)]]
    )
    zt_b = np.array([0.0, 0.0, dae.kite.zt_m])
    axis = np.array([np.cos(eps), 0.0, -np.sin(eps)])  # downwind and up (NED)
    b1 = np.array([np.sin(eps), 0.0, np.cos(eps)])  # towards the ground side of the cone
    b2 = np.array([0.0, 1.0, 0.0])
    spin = np.cross(b1, b2)  # rotation axis carrying b1 into b2
    rate = 2.0 * np.pi / guess.period_s
    radius = rho * np.sin(theta)

    n, nf = len(times_s), dae.fictitious.size
    x = np.zeros((dae.states.size, n))
    z = np.zeros((dae.algebraic.size, n))
    fict = np.zeros((nf, n))
    u0 = np.zeros(dae.controls.size)
    i_nu = dae.algebraic.index("nu_n_per_m")
    for i, t in enumerate(times_s):
        phi = rate * t
        pos = rho * np.cos(theta) * axis + radius * (np.cos(phi) * b1 + np.sin(phi) * b2)
        vel = radius * rate * (-np.sin(phi) * b1 + np.cos(phi) * b2)
        acc = -radius * rate**2 * (np.cos(phi) * b1 + np.sin(phi) * b2)
        e_x = vel / np.linalg.norm(vel)
        e_z = -pos / np.linalg.norm(pos)
        e_y = np.cross(e_z, e_x)
        dcm = np.column_stack([e_x, e_y, e_z]) @ rot_pitch
        omega_body = dcm.T @ (rate * spin)
        # rigid rotation about an axis through the winch: |bridle| is constant, so
        # l = |bridle| makes c and dc/dt exactly zero
        length = np.linalg.norm(pos + dcm @ zt_b)
        x[:, i] = dae.states.vector({
            **dict(zip(("r_x_m", "r_y_m", "r_z_m"), pos, strict=True)),
            **dict(zip(("v_x_m_s", "v_y_m_s", "v_z_m_s"), vel, strict=True)),
            **{f"dcm_{r + 1}{c + 1}": dcm[r, c] for r in range(3) for c in range(3)},
            **dict(zip(("omega_x_rad_s", "omega_y_rad_s", "omega_z_rad_s"), omega_body,
                       strict=True)),
            "l_m": length, "dl_m_s": 0.0, "ddl_m_s2": 0.0,
            "aileron_rad": 0.0, "elevator_rad": 0.0, "rudder_rad": 0.0,
        })
        z_i = dae.algebraic.vector({
            **dict(zip(("a_x_m_s2", "a_y_m_s2", "a_z_m_s2"), acc, strict=True)),
            "domega_x_rad_s2": 0.0, "domega_y_rad_s2": 0.0, "domega_z_rad_s2": 0.0,
            "nu_n_per_m": 0.0,
        })
        res0 = np.asarray(dae.alg(x[:, i], u0, z_i, wind_speed_m_s, np.zeros(nf))).ravel()
        z_i[i_nu] = 1.0
        res1 = np.asarray(dae.alg(x[:, i], u0, z_i, wind_speed_m_s, np.zeros(nf))).ravel()
        grad = res1[:3] - res0[:3]
        z_i[i_nu] = max(-float(res0[:3] @ grad) / float(grad @ grad), 0.0)
        res = np.asarray(dae.alg(x[:, i], u0, z_i, wind_speed_m_s, np.zeros(nf))).ravel()
        z[:, i] = z_i
        fict[:, i] = res[:6]
    return x, z, fict
