"""The units of drivebench's quantities: the rpm <-> rad/s factor and the unit of
a column from its name.

Columns carry their unit in the name's suffix (``speed_rpm``, ``torque_nm``,
``p_elec_w``; docs/schemas.md); :func:`unit_of` reads it back for the Parquet
field metadata every stage writes (:func:`kernel.files.write_parquet`).
"""

from __future__ import annotations

import math

#: rpm per rad/s: ``speed_rpm = speed_rad_s * RPM_PER_RAD_S`` (60 / 2 pi)
RPM_PER_RAD_S = 30.0 / math.pi

#: column-name suffix -> unit, longest match first where suffixes overlap
UNIT_SUFFIXES: tuple[tuple[str, str], ...] = (
    ("_pct_nominal", "% of nominal power"),
    ("_deg_s", "deg/s"),
    ("_kg_m3", "kg/m^3"),
    ("_kg_m2", "kg m^2"),
    ("_kg_m", "kg/m"),
    ("_rad_s2", "rad/s^2"),
    ("_rad_s", "rad/s"),
    ("_m_s3", "m/s^3"),
    ("_m_s2", "m/s^2"),
    ("_m_s", "m/s"),
    ("_n_per_m", "N/m"),
    ("_m2_s", "m^2/s"),
    ("_m2", "m^2"),
    ("_rpm", "rpm"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_nm", "N m"),
    ("_kg", "kg"),
    ("_m", "m"),
    ("_s", "s"),
    ("_n", "N"),
    ("_w", "W"),
    ("_j", "J"),
    ("_c", "degC"),
    ("_k", "K"),
    ("_pa", "Pa"),
)
#: dimensionless columns whose names carry no suffix
DIMENSIONLESS = ("eta", "eta_fit", "eta_low", "eta_high", "area_share", "r2")


def unit_of(column: str) -> str:
    """Unit of a column from its name (``torque_nm`` -> ``"N m"``); ``""`` if it has none.

    Direction-cosine entries (``dcm_*``) and the names of :data:`DIMENSIONLESS`
    are ``"1"``.
    """
    if column.startswith("dcm_") or column in DIMENSIONLESS:
        return "1"
    for suffix, unit in UNIT_SUFFIXES:
        if column.endswith(suffix):
            return unit
    return ""


def power_words(power_w: float) -> str:
    """A power in words with its unit, three significant digits: ``34.7 MW``, ``493 kW``,
    ``827 W`` (the sign kept)."""
    size = abs(power_w)
    if size >= 1e6:
        return f"{power_w / 1e6:.3g} MW"
    return f"{power_w / 1e3:.3g} kW" if size >= 1e3 else f"{power_w:.3g} W"
