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

from optimize.model.aero import altitude_above_ground, force_coefficients, wind_speed
from optimize.model.kite_model import KiteDae
from optimize.model.params import AeroCoefficients, KiteParams, WindModel

#: sine of the bank angle whose lift turns the start loop (53 deg)
LOOP_SIN_BANK = 0.8
#: start loop speed in units of the speed at which lift at the largest valid angle of
#: attack carries the weight (lift about 4 times the weight in the loop)
LOOP_SPEED_FACTOR = 2.0
#: cone half angle and lowest cone-axis elevation of the start loop [deg]
LOOP_CONE_DEG, LOOP_ELEVATION_DEG = 15.0, 30.0
#: the highest cone-axis elevation [deg]: a loop that needs more to clear the ground gets
#: a longer tether instead (overhead, the wind has no crosswind component to fly on)
LOOP_MAX_ELEVATION_DEG = 60.0
#: the start loop's mean angle of attack, as a fraction of the largest valid one
LOOP_ALPHA_FRACTION = 0.5
#: the start loop's flight speed stays this factor below the airspeed bound (the wind
#: adds to it over the loop) and its turn rate below the body-rate bound
AIRSPEED_MARGIN, BODY_RATE_MARGIN = 1.3, 0.8


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
    alpha_deg : float or None
        The loop's mean angle of attack [deg] at the wind speed it is flown in: the body
        pitch is chosen for it at each wind speed (the wind along the tether raises the
        angle of attack of a loop flown at one speed); None: ``pitch_deg`` at every wind.
    """

    period_s: float = 5.0
    tether_length_m: float = 80.0
    elevation_deg: float = 30.0
    cone_half_angle_deg: float = 15.0
    pitch_deg: float = -7.0
    alpha_deg: float | None = None


@dataclass(frozen=True)
class LoopBounds:
    """The system's bounds the start loop keeps inside.

    Parameters
    ----------
    min_airspeed_m_s : float
        Lower airspeed bound [m/s].
    period_s, tether_length_m : (float, float)
        Period [s] and tether length [m] bounds.
    min_altitude_m : float
        Lowest allowed CG altitude above ground [m].
    max_airspeed_m_s : float or None
        Upper airspeed bound [m/s] (None: none).
    max_body_rate_rad_s : float or None
        Bound of each body rate [rad/s] (None: none).
    """

    min_airspeed_m_s: float
    period_s: tuple[float, float]
    tether_length_m: tuple[float, float]
    min_altitude_m: float
    max_airspeed_m_s: float | None = None
    max_body_rate_rad_s: float | None = None


def start_loop(kite: KiteParams, coeffs: AeroCoefficients, wind: WindModel,
               alpha_max_deg: float, bounds: LoopBounds) -> LoopGuess:
    """The circular start loop of a system, inside its bounds.

    The loop is flown at :data:`LOOP_SPEED_FACTOR` times the speed at which lift at the
    largest valid angle of attack carries the weight (at least 1.5 times the minimum
    airspeed, at most the maximum over :data:`AIRSPEED_MARGIN`). Its radius is the turn
    radius ``2 (m/S) / (rho C_L sin(phi))`` at that lift coefficient and a bank ``phi``
    with ``sin(phi)`` = :data:`LOOP_SIN_BANK`, grown at the same speed where the period
    bounds (or the body-rate bound) ask for a longer loop; a period held below one turn
    at that radius flies it faster. The cone half angle :data:`LOOP_CONE_DEG` sets the
    tether length, kept inside its bounds (the cone opens or closes instead). The cone
    axis is raised from :data:`LOOP_ELEVATION_DEG` until the loop's lowest point is half
    a radius above the lowest allowed altitude; where that would take it above
    :data:`LOOP_MAX_ELEVATION_DEG`, the tether is lengthened instead. The body is pitched
    at each wind speed for a mean angle of attack of :data:`LOOP_ALPHA_FRACTION` of the
    largest valid one.

    Parameters
    ----------
    kite, coeffs, wind
        The system.
    alpha_max_deg : float
        Largest valid angle of attack [deg].
    bounds : LoopBounds
        The system's bounds the loop keeps inside.
    """
    cl = force_coefficients(math.radians(alpha_max_deg), 0.0, (0.0, 0.0, 0.0), coeffs)[0]
    loading = kite.mass_kg / kite.sref_m2
    speed = max(LOOP_SPEED_FACTOR * math.sqrt(2.0 * kite.g_m_s2 * loading / (kite.rho_kg_m3 * cl)),
                1.5 * bounds.min_airspeed_m_s)
    if bounds.max_airspeed_m_s is not None:
        speed = min(speed, bounds.max_airspeed_m_s / AIRSPEED_MARGIN)
    turn = 2.0 * loading / (kite.rho_kg_m3 * cl * LOOP_SIN_BANK)
    t_lo, t_hi = bounds.period_s
    t_lo = 1.1 * t_lo
    if bounds.max_body_rate_rad_s is not None:
        t_lo = max(t_lo, 2.0 * math.pi / (BODY_RATE_MARGIN * bounds.max_body_rate_rad_s))
    period = min(max(2.0 * math.pi * turn / speed, t_lo), t_hi / 1.1)
    radius = max(turn, speed * period / (2.0 * math.pi))
    length, cone_deg = _tether(radius, bounds.tether_length_m)
    cone = math.radians(cone_deg)
    lowest = bounds.min_altitude_m - wind.origin_altitude_m + 0.5 * length * math.sin(cone)
    top = math.radians(LOOP_MAX_ELEVATION_DEG) - cone
    if lowest > length * math.sin(top):
        length, cone_deg = _tether(radius, bounds.tether_length_m, lowest / math.sin(top))
        cone = math.radians(cone_deg)
        top = math.radians(LOOP_MAX_ELEVATION_DEG) - cone
    elevation = max(math.radians(LOOP_ELEVATION_DEG),
                    cone + math.asin(min(max(lowest / length, 0.0), math.sin(top))))
    return LoopGuess(period_s=period, tether_length_m=length,
                     elevation_deg=math.degrees(elevation), cone_half_angle_deg=cone_deg,
                     alpha_deg=LOOP_ALPHA_FRACTION * alpha_max_deg)


def _tether(radius_m: float, bounds_m: tuple[float, float], at_least_m: float = 0.0
            ) -> tuple[float, float]:
    """The tether length [m] and cone half angle [deg] of a loop of ``radius_m``: the
    cone of :data:`LOOP_CONE_DEG`, the length kept within ``bounds_m`` (20 % inside each)
    and at least ``at_least_m``; a length held off the cone's opens or closes it (up to
    twice :data:`LOOP_CONE_DEG`, the radius shrinking beyond)."""
    lo, hi = 1.2 * bounds_m[0], 0.8 * bounds_m[1]
    on_cone = radius_m / math.sin(math.radians(LOOP_CONE_DEG))
    length = min(max(on_cone, lo, at_least_m), hi)
    if length == on_cone:
        return length, LOOP_CONE_DEG
    widest = math.sin(math.radians(2.0 * LOOP_CONE_DEG))
    return length, math.degrees(math.asin(min(radius_m / length, widest)))


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
    pitch = _pitch_rad(dae, guess, wind_speed_m_s)
    # body pitch rotation (nose up for pitch > 0) about the body y axis
    rot_pitch = np.array(
        [[np.cos(pitch), 0, np.sin(pitch)], [0, 1, 0], [-np.sin(pitch), 0, np.cos(pitch)]]
    )
    zt_b = np.array([0.0, 0.0, dae.kite.zt_m])
    n, nf = len(times_s), dae.fictitious.size
    x = np.zeros((dae.states.size, n))
    z = np.zeros((dae.algebraic.size, n))
    fict = np.zeros((nf, n))
    u0 = np.zeros(dae.controls.size)
    i_nu = dae.algebraic.index("nu_n_per_m")
    for i, t in enumerate(times_s):
        pos, vel, acc, frame, omega = _loop_point(guess, 2.0 * np.pi * t / guess.period_s)
        dcm = frame @ rot_pitch
        omega_body = dcm.T @ omega
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


def _loop_point(guess: LoopGuess, phase_rad: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Position [m], velocity [m/s], acceleration [m/s^2], the unpitched body frame (its
    x along the flight path, z along the tether to the winch; columns in NED) and the
    angular velocity [rad/s] (NED) of the loop at ``phase_rad``."""
    eps = np.radians(guess.elevation_deg)
    theta = np.radians(guess.cone_half_angle_deg)
    axis = np.array([np.cos(eps), 0.0, -np.sin(eps)])  # downwind and up (NED)
    b1 = np.array([np.sin(eps), 0.0, np.cos(eps)])  # towards the ground side of the cone
    b2 = np.array([0.0, 1.0, 0.0])
    spin = np.cross(b1, b2)  # rotation axis carrying b1 into b2
    rate = 2.0 * np.pi / guess.period_s
    rho = guess.tether_length_m  # CG distance from the winch
    radius = rho * np.sin(theta)
    c, s = np.cos(phase_rad), np.sin(phase_rad)
    pos = rho * np.cos(theta) * axis + radius * (c * b1 + s * b2)
    vel = radius * rate * (-s * b1 + c * b2)
    acc = -radius * rate**2 * (c * b1 + s * b2)
    e_x = vel / np.linalg.norm(vel)
    e_z = -pos / np.linalg.norm(pos)
    return pos, vel, acc, np.column_stack([e_x, np.cross(e_z, e_x), e_z]), rate * spin


#: loop phases the mean angle of attack of :func:`_pitch_rad` is taken over
PITCH_PHASES = 36


def _pitch_rad(dae: KiteDae, guess: LoopGuess, wind_speed_m_s: float) -> float:
    """The body pitch [rad] of the loop in ``wind_speed_m_s`` [m/s] at the reference
    height: ``guess.pitch_deg``, or the pitch that makes the mean angle of attack over
    the loop ``guess.alpha_deg`` (a pitch about the body y axis adds to the angle of
    attack)."""
    if guess.alpha_deg is None:
        return float(np.radians(guess.pitch_deg))
    alphas = []
    for phase in np.linspace(0.0, 2.0 * np.pi, PITCH_PHASES, endpoint=False):
        pos, vel, _, frame, _ = _loop_point(guess, phase)
        altitude = float(altitude_above_ground(pos, dae.wind))
        air = vel - np.array([float(wind_speed(altitude, wind_speed_m_s, dae.wind)), 0.0, 0.0])
        body = frame.T @ air
        alphas.append(np.arctan2(body[2], body[0]))
    return float(np.radians(guess.alpha_deg) - np.mean(alphas))
