"""Scale factors of the OCP, relative to the system and its start loop.

Every decision variable is stored divided by a typical magnitude and every
residual row divided by its typical size. The magnitudes follow the system:
lengths from the start loop's tether length ``L``, times from its period
``T``, speeds from its flight speed ``V``, forces from the weight ``m g``,
moments from that times the chord, power from the drive's nominal power,
torque rows from the torque limit. The dimensionless factors below were chosen
so that the paper's kite gets the magnitudes the first version of this OCP was
tuned with (100 m, 30 m/s, 100 N, 10 N m, 5 s, 1 kW, 100 N m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optimize.model import kite_model as km
from optimize.problem.guess import LoopGuess
from optimize.system.params import KiteParams


@dataclass(frozen=True)
class Scales:
    """Typical magnitudes (all SI) of the OCP's variables and rows.

    Attributes
    ----------
    state, control, algebraic, fictitious : ndarray
        Per component of ``x``, ``u``, ``z`` and the fictitious forces/moments.
    residual : ndarray (7,)
        Algebraic residual rows: force [N], moment [N m], ``d2c/dt2`` [m^2/s^2].
    period_s, power_w, torque_nm, airspeed_m_s : float
    c_m2, cdot_m2_s : float
        Rows of the invariants at t = 0.
    """

    state: np.ndarray
    control: np.ndarray
    algebraic: np.ndarray
    fictitious: np.ndarray
    residual: np.ndarray
    period_s: float
    power_w: float
    torque_nm: float
    airspeed_m_s: float
    c_m2: float
    cdot_m2_s: float


def system_scales(
    kite: KiteParams,
    loop: LoopGuess,
    nominal_power_w: float,
    max_torque_nm: float,
    surface_bound_rad: float,
    surface_rate_bound_rad_s: float,
) -> Scales:
    """Scales of a system flying its start loop ``loop``.

    Parameters
    ----------
    kite : KiteParams
    loop : LoopGuess
        The start loop (tether length ``L`` [m], period ``T`` [s], cone angle).
    nominal_power_w : float
        The drive's nominal power [W].
    max_torque_nm : float
        The drive's torque limit [N m] (motor shaft).
    surface_bound_rad, surface_rate_bound_rad_s : float
        Control-surface deflection [rad] and rate [rad/s] bounds.
    """
    length = loop.tether_length_m
    period = loop.period_s
    rate = 2.0 * math.pi / period
    speed = length * math.sin(math.radians(loop.cone_half_angle_deg)) * rate
    force = 1.36 * kite.mass_kg * kite.g_m_s2
    moment = 0.4 * force * kite.cref_m
    state = np.concatenate([
        [1.25 * length] * 3, [1.15 * speed] * 3, [1.0] * 9, [2.4 * rate] * 3,
        [1.25 * length, 0.4 * speed, 0.9 * speed * rate], [1.15 * surface_bound_rad] * 3,
    ])
    control = np.array([2.4 * speed * rate**2] + [surface_rate_bound_rad_s] * 3)
    algebraic = np.array([1.5 * speed * rate] * 3 + [6.3 * rate**2] * 3
                         + [11.0 * kite.mass_kg * kite.g_m_s2 / length])
    fictitious = np.array([force] * 3 + [moment] * 3)
    residual = np.array([force] * 3 + [moment] * 3 + [1.5 * speed**2])
    assert state.shape == (km.NX,)
    return Scales(
        state=state, control=control, algebraic=algebraic, fictitious=fictitious,
        residual=residual, period_s=period, power_w=nominal_power_w / 8.0,
        torque_nm=1.3 * max_torque_nm, airspeed_m_s=1.15 * speed, c_m2=0.016 * length**2,
        cdot_m2_s=0.5 * length * speed,
    )
