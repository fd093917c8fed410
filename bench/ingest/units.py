"""Units recognised by ingest (docs/schemas.md section 1) and their factors to our units.

Inside the store speed is in rpm, torque in N m, power in W and time in s; the
factor returned here multiplies a logged value to give that unit.
"""

from __future__ import annotations

import math
import re

#: our unit per quantity (the unit in the store's column name)
TARGET_UNIT: dict[str, str] = {
    "time": "s",
    "speed": "rpm",
    "torque": "N m",
    "power": "W",
}

_RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)

#: quantity -> {normalised unit spelling -> factor to the target unit}
_FACTORS: dict[str, dict[str, float]] = {
    # clock formats (time of day, ISO 8601) are parsed to seconds by bench.ingest.clock
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6,
             "hh:mm:ss": 1.0, "hh:mm:ss.sss": 1.0, "hh:mm:ss,sss": 1.0, "iso8601": 1.0},
    "speed": {
        "rpm": 1.0,
        "1/min": 1.0,
        "u/min": 1.0,
        "min^-1": 1.0,
        "min-1": 1.0,
        "rad/s": _RPM_PER_RAD_S,
    },
    "torque": {"nm": 1.0, "n·m": 1.0, "n*m": 1.0, "knm": 1e3},
    "power": {"w": 1.0, "kw": 1e3, "mw": 1e6},
}

#: the spellings to show in error messages
ACCEPTED: dict[str, str] = {
    "time": "s, ms, us, hh:mm:ss (time of day), ISO 8601 (date-time)",
    "speed": "rpm, 1/min, U/min, min^-1, min-1, rad/s",
    "torque": "N m, Nm, N·m, N*m, kNm, kN m",
    "power": "W, kW, MW",
}

#: our quantities -> physical kind (std columns share their quantity's unit)
QUANTITY_KIND: dict[str, str] = {
    "time": "time",
    "speed": "speed",
    "torque": "torque",
    "p_elec": "power",
    "p_mech": "power",
    "speed_std": "speed",
    "torque_std": "torque",
    "p_elec_std": "power",
    "p_mech_std": "power",
}


def normalise_unit(unit: str) -> str:
    """Lower-case a unit and drop all whitespace (``'kN m'`` -> ``'knm'``)."""
    return re.sub(r"\s+", "", unit).lower()


def unit_factor(kind: str, unit: str) -> float | None:
    """Factor from ``unit`` to our unit of ``kind`` (``time``, ``speed``, ``torque``, ``power``).

    Parameters
    ----------
    kind : str
        Physical kind, a key of :data:`TARGET_UNIT`.
    unit : str
        The unit as written in the file (case- and whitespace-insensitive).

    Returns
    -------
    float or None
        The multiplier to our unit, or None when the unit is not recognised.
    """
    return _FACTORS[kind].get(normalise_unit(unit))


_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")


def split_header(header: str) -> tuple[str, str | None]:
    """Split a ``'Name [unit]'`` (or ``'Name (unit)'``) header into name and unit.

    Returns ``(name, None)`` when the header carries no unit.
    """
    m = _HEADER_UNIT.match(header.strip())
    if m is None:
        return header.strip(), None
    return m.group("name").strip(), m.group("unit").strip()
