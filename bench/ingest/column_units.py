"""Units recognised by ingest (docs/schemas.md section 1) and their factors to our units.

Inside the store speed is in rpm, torque in N m, power in W and time in s; the
factor returned here multiplies a logged value to give that unit.

Spellings are matched after dropping whitespace and the product signs ``·``,
``*``, ``.`` and ``-`` between letters (``kN m``, ``kN·m``, ``lbf-ft``), with
``µ``/``μ`` read as ``u``. Case carries meaning where it must: ``mW`` is a
milliwatt and ``MW`` a megawatt, ``mNm`` a millinewton metre and ``MNm`` a
meganewton metre. A spelling in another case (``KW``, ``RPM``, ``NM``) is
accepted only when every unit it could stand for has the same factor; ``mw`` or
``MNM`` are refused as ambiguous.
"""

from __future__ import annotations

import math
import re

from kernel.units import RPM_PER_RAD_S

#: our unit per quantity (the unit in the store's column name)
TARGET_UNIT: dict[str, str] = {
    "time": "s",
    "speed": "rpm",
    "torque": "N m",
    "power": "W",
    "temperature": "degC",
}

_NM_PER_LBF_FT = 1.3558179483314004  # 1 lbf ft = 0.3048 m * 4.4482216152605 N
_NM_PER_LBF_IN = _NM_PER_LBF_FT / 12.0

#: kind -> [(spelling as shown to users, factor to the target unit)], spellings
#: in their meaningful case; the first spelling per factor names that unit
_UNITS: dict[str, list[tuple[str, float]]] = {
    # clock formats (time of day, ISO 8601): parsed to seconds by bench.ingest.clock
    "time": [("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("µs", 1e-6),
             ("hh:mm:ss", 1.0), ("hh:mm:ss.sss", 1.0), ("hh:mm:ss,sss", 1.0), ("ISO 8601", 1.0)],
    "speed": [
        ("rpm", 1.0), ("1/min", 1.0), ("U/min", 1.0), ("r/min", 1.0), ("rev/min", 1.0),
        ("min^-1", 1.0), ("min-1", 1.0), ("min⁻¹", 1.0), ("krpm", 1e3),
        ("rad/s", RPM_PER_RAD_S),
    ],
    "torque": [
        ("N m", 1.0), ("Nm", 1.0), ("N·m", 1.0), ("N*m", 1.0), ("N.m", 1.0),
        ("mN m", 1e-3), ("mNm", 1e-3),
        ("N mm", 1e-3), ("Nmm", 1e-3),
        ("N cm", 1e-2), ("Ncm", 1e-2),
        ("daN m", 10.0), ("daNm", 10.0),
        ("kN m", 1e3), ("kNm", 1e3),
        ("MN m", 1e6), ("MNm", 1e6),
        ("lbf ft", _NM_PER_LBF_FT), ("lbf-ft", _NM_PER_LBF_FT), ("lb ft", _NM_PER_LBF_FT),
        ("ft lbf", _NM_PER_LBF_FT), ("ft lb", _NM_PER_LBF_FT),
        ("lbf in", _NM_PER_LBF_IN), ("lbf-in", _NM_PER_LBF_IN), ("lb in", _NM_PER_LBF_IN),
        ("in lbf", _NM_PER_LBF_IN), ("in lb", _NM_PER_LBF_IN),
    ],
    "power": [("W", 1.0), ("mW", 1e-3), ("kW", 1e3), ("MW", 1e6)],
    # kelvin has factor 1 too: its offset is in KELVIN_SPELLINGS / unit_offset
    "temperature": [("degC", 1.0), ("deg C", 1.0), ("°C", 1.0), ("℃", 1.0), ("Cel", 1.0),
                    ("K", 1.0)],
}

#: spellings of the kelvin (a temperature in K is converted to degC by its offset)
KELVIN_SPELLINGS = frozenset({"K"})

#: 0 degC in kelvin [K]
KELVIN_AT_0C = 273.15


def _compact(unit: str) -> str:
    """Drop whitespace, one enclosing pair of brackets or parentheses (a units row's
    ``[s]`` or ``(Nm)``) and product signs, ``µ`` -> ``u`` (case kept)."""
    u = re.sub(r"\s+", "", unit).replace("µ", "u").replace("μ", "u")
    u = re.sub(r"^\[([^\[\]()]*)\]$|^\(([^\[\]()]*)\)$", r"\1\2", u)
    return re.sub(r"(?<=[A-Za-z])[·⋅*.\-](?=[A-Za-z])", "", u)


#: kind -> {compacted spelling -> factor}
_EXACT: dict[str, dict[str, float]] = {
    kind: {_compact(s): f for s, f in spellings} for kind, spellings in _UNITS.items()
}

#: the spellings to show in error messages
ACCEPTED: dict[str, str] = {
    kind: ", ".join(s for s, _ in spellings) for kind, spellings in _UNITS.items()
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
    "t_winding": "temperature",
    "t_housing": "temperature",
    "t_coolant": "temperature",
    "t_ambient": "temperature",
}


def normalise_unit(unit: str) -> str:
    """Lower-case a unit and drop whitespace and product signs (``'kN m'`` -> ``'knm'``)."""
    return _compact(unit).lower()


def _candidates(kind: str, unit: str) -> dict[str, float]:
    """Spellings of ``kind`` that ``unit`` matches without regard to case."""
    low = normalise_unit(unit)
    return {s: f for s, f in _UNITS[kind] if normalise_unit(s) == low}


def unit_factor(kind: str, unit: str) -> float | None:
    """Factor from ``unit`` to our unit of ``kind`` (``time``, ``speed``, ``torque``, ``power``).

    Parameters
    ----------
    kind : str
        Physical kind, a key of :data:`TARGET_UNIT`.
    unit : str
        The unit as written in the file (whitespace-insensitive; case-insensitive
        only where no other unit differs from it by case alone).

    Returns
    -------
    float or None
        The multiplier to our unit, or None when the unit is unknown or ambiguous.
    """
    exact = _EXACT[kind].get(_compact(unit))
    if exact is not None:
        return exact
    factors = set(_candidates(kind, unit).values())
    return factors.pop() if len(factors) == 1 else None


def unit_offset(kind: str, unit: str) -> float:
    """What to add after :func:`unit_factor` to reach our unit: -273.15 for a temperature in
    K (to degC), else 0."""
    return -KELVIN_AT_0C if kind == "temperature" and _compact(unit) in KELVIN_SPELLINGS else 0.0


def unit_problem(kind: str, unit: str) -> str:
    """Why :func:`unit_factor` refused ``unit``: ``'unknown unit ...'`` or ``'ambiguous ...'``."""
    names = {}
    for s, f in _candidates(kind, unit).items():
        names.setdefault(f, s)
    if len(names) > 1:
        spelled = " or ".join(f"{s!r} (x{f:g})" for f, s in sorted(names.items()))
        return f"ambiguous unit {unit!r}: case tells {spelled} apart"
    return f"unknown unit {unit!r}"


def alternatives(kind: str, unit: str) -> list[tuple[str, float]]:
    """Other units of ``kind`` with a different factor: ``[(name, factor / factor of unit)]``.

    One name per distinct factor (the first spelling of :data:`_UNITS`); used to
    suggest which unit a column that fails a plausibility check may really be in.
    """
    own = unit_factor(kind, unit)
    if own is None:
        return []
    seen: dict[float, str] = {}
    for s, f in _UNITS[kind]:
        if not math.isclose(f, own, rel_tol=1e-9):
            seen.setdefault(f, s)
    return [(s, f / own) for f, s in seen.items()]


_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")


def split_header(header: str) -> tuple[str, str | None]:
    """Split a ``'Name [unit]'`` (or ``'Name (unit)'``) header into name and unit.

    Returns ``(name, None)`` when the header carries no unit.
    """
    m = _HEADER_UNIT.match(header.strip())
    if m is None:
        return header.strip(), None
    return m.group("name").strip(), m.group("unit").strip()
