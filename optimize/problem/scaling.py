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
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optimize.model.params import KiteParams
from optimize.problem.guess import LoopGuess


@dataclass(frozen=True)
class Scales:
    """Typical magnitudes (all SI) of the OCP's variables and rows.

    Attributes
    ----------
    state, control, algebraic, fictitious : ndarray
        Per component of ``x``, ``u``, ``z`` and the fictitious forces/moments (the
        parts' :meth:`optimize.problem.part.Part.scales`, set by the formulation;
        empty until then).
    residual : ndarray (7,)
        Algebraic residual rows: force [N], moment [N m], ``d2c/dt2`` [m^2/s^2].
    period_s, power_w, torque_nm, airspeed_m_s : float
    c_m2, cdot_m2_s : float
        Rows of the invariants at t = 0.
    length_m, speed_m_s, rate_rad_s, force_n, moment_nm : float
        The start loop's tether length, flight speed and turn rate, the force and moment
        magnitudes the kite's variables are scaled from.
    """

    residual: np.ndarray
    period_s: float
    power_w: float
    torque_nm: float
    airspeed_m_s: float
    c_m2: float
    cdot_m2_s: float
    length_m: float
    speed_m_s: float
    rate_rad_s: float
    force_n: float
    moment_nm: float
    state: np.ndarray = field(default_factory=lambda: np.zeros(0))
    control: np.ndarray = field(default_factory=lambda: np.zeros(0))
    algebraic: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fictitious: np.ndarray = field(default_factory=lambda: np.zeros(0))


def system_scales(
    kite: KiteParams,
    loop: LoopGuess,
    drive: Any,
) -> Scales:
    """Scales of a system flying its start loop ``loop`` (the per-variable ones come
    from the parts, :meth:`optimize.problem.part.Part.scales`).

    Parameters
    ----------
    kite : KiteParams
        The kite's parameters.
    loop : LoopGuess
        The start loop (tether length ``L`` [m], period ``T`` [s], cone angle).
    drive : kernel.drive.Drive
        The drive in force: its nominal power [W] scales the powers, its torque limit
        [N m] (motor shaft) the torques.
    """
    length = loop.tether_length_m
    period = loop.period_s
    rate = 2.0 * math.pi / period
    speed = length * math.sin(math.radians(loop.cone_half_angle_deg)) * rate
    force = 1.36 * kite.mass_kg * kite.g_m_s2
    moment = 0.4 * force * kite.cref_m
    residual = np.array([force] * 3 + [moment] * 3 + [1.5 * speed**2])
    return Scales(
        residual=residual, period_s=period, power_w=drive.nominal_power_w / 8.0,
        torque_nm=1.3 * drive.max_torque_nm, airspeed_m_s=1.15 * speed, c_m2=0.016 * length**2,
        cdot_m2_s=0.5 * length * speed, length_m=length, speed_m_s=speed, rate_rad_s=rate,
        force_n=force, moment_nm=moment,
    )
