"""Number formatting and generic tables for the report template."""

from __future__ import annotations

import math
import re
from numbers import Number

import numpy as np
import pandas as pd

from reports.inputs import InputLog

_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def fmt(value, decimals: int | None = None, sig: int | None = None) -> str:
    """Format a number for a table cell; '' for None, 'n/a' for NaN.

    Parameters
    ----------
    value : number or None
    decimals : int, optional
        Fixed decimals.
    sig : int, optional
        Significant digits (``g`` format); used when ``decimals`` is not given.
    """
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if not isinstance(value, Number):
        return str(value)
    v = float(value)
    if math.isnan(v):
        return "n/a"
    if decimals is not None:
        return f"{v:.{decimals}f}"
    if 10 ** (sig or 4) <= abs(v) < 1e15:  # no exponent for a large number: 12300, not 1.23e+04
        return f"{v:.0f}"
    return f"{v:.{sig or 4}g}"


def value_text(value) -> str:
    """A setting's value for a table: ``not set`` for None, yes/no for a boolean, a number
    by :func:`fmt`, a list comma-separated (``none`` when empty), else its text."""
    if value is None:
        return "not set"
    if isinstance(value, list | tuple):
        return ", ".join(value_text(v) for v in value) or "none"
    if isinstance(value, bool | np.bool_ | Number):
        return fmt(value)
    return str(value)


def term_label(term: tuple[int, int]) -> str:
    """Readable term label (ω speed, T torque): ``(2, 1)`` -> ``ω²·T``, ``(0, 0)`` -> ``1``."""
    parts = []
    for sym, e in (("ω", term[0]), ("T", term[1])):
        if e == 1:
            parts.append(sym)
        elif e > 1:
            parts.append(sym + str(e).translate(_SUPERSCRIPT))
    return "·".join(parts) if parts else "1"


#: unit suffixes of the files' column names (docs/schemas.md Conventions) -> the unit said
#: in a table's header; the longest suffix that fits wins
UNIT_SUFFIXES = {"m_s2": "m/s²", "m_s": "m/s", "kg_m2": "kg m²", "nm": "N m", "rpm": "rpm",
                 "w": "W", "j": "J", "s": "s", "m": "m", "c": "°C", "k": "K", "deg": "deg",
                 "frac": "share", "mwh": "MWh/yr", "hz": "Hz"}


def header_label(column: str) -> str:
    """A file's column name as a table header: words, the unit in brackets
    (``wind_speed_m_s`` -> ``wind speed [m/s]``); a name without a unit suffix keeps its
    words (``bound_limited`` -> ``bound limited``)."""
    words = str(column).split("_")
    unit = None
    for n in (2, 1):
        if UNIT_SUFFIXES.get("_".join(words[-n:])) is not None and len(words) > n:
            unit, words = UNIT_SUFFIXES["_".join(words[-n:])], words[:-n]
            break
    text = re.sub(r"\b([pe]) (elec|mech)\b", lambda m: f"{m[1].upper()}_{m[2]}",
                  " ".join(words))
    return text if unit is None else f"{text} [{unit}]"


def frame_table(frame: pd.DataFrame, max_rows: int = 200) -> dict:
    """A frame as ``{"columns": [...], "rows": [[str, ...], ...], "truncated": int}``.

    Columns are headed by :func:`header_label`; floats get 4 significant digits, booleans
    yes/no; every cell is a plain string (the template escapes it).
    """
    shown = frame.head(max_rows)
    rows = [[_cell(v) for v in rec] for rec in shown.itertuples(index=False, name=None)]
    return {
        "columns": [header_label(c) for c in frame.columns],
        "rows": rows,
        "truncated": max(0, len(frame) - max_rows),
    }


def _cell(value) -> str:
    if value is None:  # a figure the record lacks: said, never an empty cell
        return "n/a"
    if isinstance(value, (list, tuple, np.ndarray)):
        return ", ".join(_cell(v) for v in value)
    if isinstance(value, float) and abs(value) >= 1e4 and value == round(value):
        return f"{value:.0f}"
    return fmt(value)


def missing_since(log: InputLog, start: int) -> list[str]:
    """The files ``log`` found missing since its ``start``-th record, each once."""
    return list(dict.fromkeys(log.missing[start:]))


def flatten(data: dict, prefix: str = "") -> list[tuple[str, str]]:
    """Nested dict as (dotted key, text) pairs; lists of records are skipped (own tables)."""
    out = []
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.extend(flatten(value, name + "."))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            continue
        else:
            out.append((name, value_text(value)))
    return out
