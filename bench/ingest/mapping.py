"""Column mapping: which column of a file holds which of our quantities, in which unit.

A mapping file (TOML or JSON, docs/schemas.md section 1) names foreign columns;
columns it does not name are recognised from ``Name [unit]`` headers (or a
units row) by the aliases below, so our own instruments need no mapping file.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from bench.errors import InputError
from bench.ingest.units import ACCEPTED, QUANTITY_KIND, split_header, unit_factor

#: file sections a mapping may describe, and the quantities each may name
SECTION_QUANTITIES: dict[str, tuple[str, ...]] = {
    "points": (
        "speed", "torque", "p_elec", "p_mech",
        "speed_std", "torque_std", "p_elec_std", "p_mech_std", "n_samples",
    ),
    "daq": ("time", "speed", "torque"),
    "analyzer": ("time", "p_elec"),
    "log": ("time", "speed", "torque", "p_elec", "p_mech"),
}

#: header names (unit stripped, lower case) recognised without a mapping
ALIASES: dict[str, tuple[str, ...]] = {
    "time": ("time", "zeit", "t", "time_s", "timestamp", "zeitstempel", "uhrzeit", "datetime"),
    "speed": ("speed", "drehzahl", "n", "speed_rpm", "rotational speed"),
    "torque": ("torque", "drehmoment", "m", "torque_nm"),
    "p_elec": ("p_sigma", "p_elec", "p_el", "p", "p_total", "wirkleistung", "p_elec_w"),
    "p_mech": ("p_mech", "p_mech_w"),
}


@dataclass(frozen=True)
class ColumnSpec:
    """One mapped column.

    Parameters
    ----------
    column : str
        The column name as written in the file.
    unit : str
        Its unit (docs/schemas.md unit table; ``""`` for counts).
    """

    column: str
    unit: str


@dataclass(frozen=True)
class Mapping:
    """A parsed mapping file: per section, quantity -> :class:`ColumnSpec`.

    Parameters
    ----------
    path : Path or None
        Where it was read from (for error messages); None for the empty mapping.
    sections : dict
        ``{"points"|"daq"|"analyzer": {quantity: ColumnSpec}}``.
    """

    path: Path | None = None
    sections: dict[str, dict[str, ColumnSpec]] = field(default_factory=dict)

    def section(self, name: str) -> dict[str, ColumnSpec]:
        """Entries of one section (empty when the mapping does not mention it)."""
        return self.sections.get(name, {})


EMPTY_MAPPING = Mapping()


def load_mapping(path: str | Path) -> Mapping:
    """Read and validate a TOML (``.toml``) or JSON (``.json``) mapping file.

    Raises
    ------
    InputError
        Unreadable file, unknown section or quantity, missing ``column``/``unit``,
        or an unknown unit.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read mapping file ({exc})") from exc
    try:
        raw = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(
            path, f"not a valid mapping file ({exc})", expected="TOML or JSON"
        ) from exc
    sections: dict[str, dict[str, ColumnSpec]] = {}
    if "columns" in raw:
        sections["points"] = _parse_columns(path, "columns", raw["columns"], "points")
    for name in ("daq", "analyzer", "log"):
        if name in raw:
            if not isinstance(raw[name], dict) or set(raw[name]) != {"columns"}:
                raise InputError(path, f"section [{name}] must hold only [{name}.columns.*] tables")
            sections[name] = _parse_columns(path, f"{name}.columns", raw[name]["columns"], name)
    unknown = set(raw) - {"columns", "daq", "analyzer", "log"}
    if unknown:
        raise InputError(
            path, f"unknown mapping section(s) {sorted(unknown)}",
            expected="[columns.*], [daq.columns.*], [analyzer.columns.*] or [log.columns.*]",
        )
    return Mapping(path=path, sections=sections)


def _parse_columns(path: Path, where: str, table: object, section: str) -> dict[str, ColumnSpec]:
    if not isinstance(table, dict):
        raise InputError(path, f"[{where}] must be a table of quantities")
    out: dict[str, ColumnSpec] = {}
    for quantity, entry in table.items():
        if quantity not in SECTION_QUANTITIES[section]:
            raise InputError(
                path, f"unknown quantity [{where}.{quantity}]",
                expected="one of " + ", ".join(SECTION_QUANTITIES[section]),
            )
        if not isinstance(entry, dict) or set(entry) != {"column", "unit"}:
            raise InputError(path, f"[{where}.{quantity}] must have exactly 'column' and 'unit'")
        spec = ColumnSpec(str(entry["column"]), str(entry["unit"]))
        if quantity != "n_samples" and unit_factor(QUANTITY_KIND[quantity], spec.unit) is None:
            kind = QUANTITY_KIND[quantity]
            raise InputError(
                path, f"unknown unit {spec.unit!r} for {quantity}", column=spec.column,
                expected=ACCEPTED[kind],
            )
        out[quantity] = spec
    return out


@dataclass(frozen=True)
class ResolvedColumn:
    """Where a quantity sits in a file and how to convert it.

    Parameters
    ----------
    index : int
        0-based column index in the file.
    header : str
        The column's header as written.
    unit : str
        The unit as written (or as the mapping says).
    factor : float
        Multiplier to our unit (1.0 for counts).
    """

    index: int
    header: str
    unit: str
    factor: float


def resolve_columns(
    path: Path,
    headers: list[str],
    units_row: list[str] | None,
    section: str,
    required: tuple[str, ...],
    optional: tuple[str, ...] = (),
    mapping: Mapping = EMPTY_MAPPING,
    header_line: int | None = None,
) -> dict[str, ResolvedColumn]:
    """Find each wanted quantity among a file's columns, from the mapping or by alias.

    Parameters
    ----------
    path : Path
        The data file (for error messages).
    headers : list of str
        Its column names as written.
    units_row : list of str or None
        A units row under the names (German exports), else None.
    section : str
        ``"daq"``, ``"analyzer"`` or ``"points"``.
    required, optional : tuple of str
        Quantities that must be found / may be found.
    mapping : Mapping
        Explicit column names; they win over aliases.
    header_line : int, optional
        1-based line of the names row.

    Returns
    -------
    dict
        quantity -> :class:`ResolvedColumn`.

    Raises
    ------
    InputError
        A mapped column that does not exist (names the mapping file), a missing
        required column, or a column whose unit is missing or unknown.
    """
    stripped = [h.strip() for h in headers]
    bare = [split_header(h)[0].lower() for h in stripped]
    found: dict[str, ResolvedColumn] = {}
    for quantity, spec in mapping.section(section).items():
        if quantity not in required + optional:
            continue
        idx = _find_mapped(stripped, bare, spec.column)
        if idx is None:
            raise InputError(
                mapping.path, f"mapping names column {spec.column!r} for {quantity}, "
                f"but {path.name} has no such column", column=spec.column,
                expected="one of the file's columns: " + ", ".join(repr(h) for h in stripped),
            )
        factor = 1.0 if quantity == "n_samples" else unit_factor(QUANTITY_KIND[quantity], spec.unit)
        found[quantity] = ResolvedColumn(idx, stripped[idx], spec.unit, float(factor))
    for quantity in required + optional:
        if quantity in found:
            continue
        idx = next((i for i, b in enumerate(bare) if b in ALIASES.get(quantity, ())), None)
        if idx is None:
            if quantity in required:
                raise InputError(
                    path, f"missing column for {quantity}", line=header_line, column=quantity,
                    expected=f"a column named like {ALIASES[quantity][0].title()!r} with a unit, "
                    f"or a mapping entry [{section}.columns.{quantity}]; found columns: "
                    + ", ".join(repr(h) for h in stripped),
                )
            continue
        unit = split_header(stripped[idx])[1]
        if units_row is not None and idx < len(units_row) and units_row[idx].strip():
            unit = units_row[idx].strip()
        kind = QUANTITY_KIND[quantity]
        if unit is None:
            raise InputError(
                path, f"column has no unit for {quantity}", line=header_line,
                column=stripped[idx], expected=f"'Name [unit]' with unit one of {ACCEPTED[kind]}",
            )
        factor = unit_factor(kind, unit)
        if factor is None:
            raise InputError(
                path, f"unknown unit {unit!r} for {quantity}", line=header_line,
                column=stripped[idx], expected=ACCEPTED[kind],
            )
        found[quantity] = ResolvedColumn(idx, stripped[idx], unit, factor)
    return found


def _find_mapped(stripped: list[str], bare: list[str], column: str) -> int | None:
    """Index of a mapped column: exact header first, then the name without its unit."""
    if column in stripped:
        return stripped.index(column)
    low = column.strip().lower()
    return bare.index(low) if low in bare else None
