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

from dataclasses import dataclass

import numpy as np

from optimize.model.kite_model import NF, NX, NZ, KiteDae


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


def circular_loop(
    dae: KiteDae, guess: LoopGuess, times_s: np.ndarray, wind_ref_m_s: float
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

    n = len(times_s)
    x = np.zeros((NX, n))
    z = np.zeros((NZ, n))
    fict = np.zeros((NF, n))
    u0 = np.zeros(4)
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
        x[:, i] = np.concatenate(
            [pos, vel, dcm.flatten(order="F"), omega_body, [length, 0, 0], [0, 0, 0]]
        )
        z_i = np.concatenate([acc, [0.0, 0.0, 0.0], [0.0]])
        res0 = np.asarray(dae.alg(x[:, i], u0, z_i, wind_ref_m_s, np.zeros(NF))).ravel()
        z_i[6] = 1.0
        res1 = np.asarray(dae.alg(x[:, i], u0, z_i, wind_ref_m_s, np.zeros(NF))).ravel()
        grad = res1[:3] - res0[:3]
        z_i[6] = max(-float(res0[:3] @ grad) / float(grad @ grad), 0.0)
        res = np.asarray(dae.alg(x[:, i], u0, z_i, wind_ref_m_s, np.zeros(NF))).ravel()
        z[:, i] = z_i
        fict[:, i] = res[:6]
    return x, z, fict
