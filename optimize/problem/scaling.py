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

from optimize.model.kite_model import KiteDae
from optimize.problem.guess import LoopGuess


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
    dae: KiteDae,
    loop: LoopGuess,
    nominal_power_w: float,
    max_torque_nm: float,
    surface_bound_rad: float,
    surface_rate_bound_rad_s: float,
) -> Scales:
    """Scales of a system flying its start loop ``loop``.

    Parameters
    ----------
    dae : KiteDae
        The kite model: its parameters, and the names the state scales follow.
    loop : LoopGuess
        The start loop (tether length ``L`` [m], period ``T`` [s], cone angle).
    nominal_power_w : float
        The drive's nominal power [W].
    max_torque_nm : float
        The drive's torque limit [N m] (motor shaft).
    surface_bound_rad, surface_rate_bound_rad_s : float
        Control-surface deflection [rad] and rate [rad/s] bounds.
    """
    kite = dae.kite
    length = loop.tether_length_m
    period = loop.period_s
    rate = 2.0 * math.pi / period
    speed = length * math.sin(math.radians(loop.cone_half_angle_deg)) * rate
    force = 1.36 * kite.mass_kg * kite.g_m_s2
    moment = 0.4 * force * kite.cref_m
    state = dae.states.vector({
        **{f"r_{a}_m": 1.25 * length for a in "xyz"},
        **{f"v_{a}_m_s": 1.15 * speed for a in "xyz"},
        **{f"dcm_{i}{j}": 1.0 for i in (1, 2, 3) for j in (1, 2, 3)},
        **{f"omega_{a}_rad_s": 2.4 * rate for a in "xyz"},
        "l_m": 1.25 * length, "dl_m_s": 0.4 * speed, "ddl_m_s2": 0.9 * speed * rate,
        **{f"{s}_rad": 1.15 * surface_bound_rad for s in ("aileron", "elevator", "rudder")},
    })
    control = dae.controls.vector({
        "dddl_m_s3": 2.4 * speed * rate**2,
        **{f"d{s}_rad_s": surface_rate_bound_rad_s for s in ("aileron", "elevator", "rudder")},
    })
    algebraic = dae.algebraic.vector({
        **{f"a_{a}_m_s2": 1.5 * speed * rate for a in "xyz"},
        **{f"domega_{a}_rad_s2": 6.3 * rate**2 for a in "xyz"},
        "nu_n_per_m": 11.0 * kite.mass_kg * kite.g_m_s2 / length,
    })
    fictitious = dae.fictitious.vector({
        **{f"f_fict_{a}_n": force for a in "xyz"}, **{f"m_fict_{a}_nm": moment for a in "xyz"},
    })
    residual = np.array([force] * 3 + [moment] * 3 + [1.5 * speed**2])
    return Scales(
        state=state, control=control, algebraic=algebraic, fictitious=fictitious,
        residual=residual, period_s=period, power_w=nominal_power_w / 8.0,
        torque_nm=1.3 * max_torque_nm, airspeed_m_s=1.15 * speed, c_m2=0.016 * length**2,
        cdot_m2_s=0.5 * length * speed,
    )
