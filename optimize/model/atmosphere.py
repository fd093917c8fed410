"""Air density over altitude: constant, or the International Standard Atmosphere.

The ISA troposphere (ISO 2533:1975; U.S. Standard Atmosphere 1976, the same below
11 km): the temperature falls linearly, ``T(h) = T0 - L h``, and the air is an ideal
gas in hydrostatic equilibrium, so

    rho(h) = rho0 (T(h) / T0)^(g / (R L) - 1)

with ``T0 = 288.15 K``, ``R = 287.053 J/(kg K)`` and the lapse rate ``L``
(0.0065 K/m). awebox uses the same law (awebox/awebox, ``awebox/mdl/atmosphere.py``,
``get_density`` of model ``'isa'``). The altitude is above the ground, taken as
sea level (``rho0`` is the density there). Pure functions of numbers or CasADi
expressions.
"""

from __future__ import annotations

from typing import Any

#: ISA sea-level temperature [K] (ISO 2533:1975)
ISA_T0_K = 288.15
#: specific gas constant of dry air [J/(kg K)] (ISO 2533:1975)
ISA_R_J_KG_K = 287.053
#: ISA troposphere temperature lapse rate [K/m] (ISO 2533:1975)
ISA_LAPSE_K_M = 0.0065


def air_density(altitude_m: Any, rho0_kg_m3: float, gravity_m_s2: float,
                lapse_k_m: float) -> Any:
    """Air density [kg/m^3] at ``altitude_m`` above the ground [m].

    Parameters
    ----------
    altitude_m : float, array or CasADi expression
        Altitude above the ground (sea level) [m].
    rho0_kg_m3 : float
        Density at the ground [kg/m^3].
    gravity_m_s2 : float
        Gravitational acceleration [m/s^2].
    lapse_k_m : float
        Temperature lapse rate [K/m]; 0 returns ``rho0_kg_m3`` itself (a constant
        density, the same number whatever the altitude).
    """
    if lapse_k_m == 0:
        return rho0_kg_m3
    ratio = 1.0 - lapse_k_m * altitude_m / ISA_T0_K
    return rho0_kg_m3 * ratio ** (gravity_m_s2 / (ISA_R_J_KG_K * lapse_k_m) - 1.0)
