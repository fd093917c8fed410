"""Column mapping: which column of a file holds which of our quantities, in which unit.

A mapping file (TOML or JSON, docs/schemas.md section 1) names foreign columns,
combines several (``sum``, ``expr``) and says how many lines to skip before a
file's header (``skip_lines``). Columns it does not name are recognised from
``Name [unit]`` headers (or a units row) by the aliases below, so our own
instruments need no mapping file; p_mech is only ever taken from a mapping.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bench.ingest import expr
from bench.ingest.column_units import (
    ACCEPTED,
    QUANTITY_KIND,
    split_header,
    unit_factor,
    unit_offset,
    unit_problem,
)
from bench.ingest.temperature import ALIASES as TEMPERATURE_ALIASES
from bench.ingest.temperature import TEMPERATURES
from kernel.errors import InputError
from kernel.files import parse_json, parse_toml, read_text

#: file sections a mapping may describe, and the quantities each may name
SECTION_QUANTITIES: dict[str, tuple[str, ...]] = {
    "points": (
        "speed", "torque", "p_elec", "p_mech",
        "speed_std", "torque_std", "p_elec_std", "p_mech_std", "n_samples",
    ),
    "daq": ("time", "speed", "torque", "sample_counter", *TEMPERATURES),
    "analyzer": ("time", "p_elec", "sample_counter"),
    "log": ("time", "speed", "torque", "p_elec", "p_mech", "sample_counter", *TEMPERATURES),
}

#: a stream's optional sample counter: ``column`` and ``rate_hz``; the time is the
#: stamp plus counter / rate_hz (the counter numbers the rows within a stamp)
COUNTER = "sample_counter"

#: the sections written as ``[<name>.columns.*]`` (points use top-level ``[columns.*]``)
STREAM_SECTIONS = ("daq", "analyzer", "log")

#: header names (unit stripped, lower case) recognised without a mapping; p_mech has
#: none on purpose: a column that merely looks like it (a swapped header) must never
#: be used unless the mapping names it
ALIASES: dict[str, tuple[str, ...]] = {
    "time": ("time", "zeit", "t", "time_s", "timestamp", "zeitstempel", "uhrzeit", "datetime",
             "date/time", "date time", "date_time", "datum/zeit", "datum/uhrzeit"),
    "speed": ("speed", "drehzahl", "n", "speed_rpm", "rotational speed"),
    "torque": ("torque", "drehmoment", "m", "torque_nm"),
    "p_elec": ("p_sigma", "p_elec", "p_el", "p", "p_total", "wirkleistung", "p_elec_w",
               "active power", "electrical power", "input power", "power", "leistung"),
    **TEMPERATURE_ALIASES,
}

#: aliases a column matches only when no earlier alias of the quantity matches and no
#: other column has the same name (a plain ``Power`` beside ``P_mech`` may be either)
WEAK_ALIASES = frozenset({"power", "leistung"})

#: how many column names an error message lists at most
MAX_LISTED = 6

#: lines ``skip_lines`` may skip at most (a title block, not a file)
MAX_SKIP_LINES = 1000


@dataclass(frozen=True)
class ColumnSpec:
    """One mapped quantity: a column, a sum of columns or an expression over columns.

    Parameters
    ----------
    column : str
        The column name as written in the file; for ``sum`` and ``expr`` entries
        the expression text (``{P_1 [W]} + {P_2 [W]}``).
    unit : str
        The unit of the column or of the combination's result (docs/schemas.md
        unit table; ``""`` for counts).
    formula : expr.Node or None
        The parsed combination; None for a single column.
    rate_hz : float or None
        The rows per second a ``sample_counter`` counts [Hz] (None otherwise).
    """

    column: str
    unit: str
    formula: expr.Node | None = None
    rate_hz: float | None = None


@dataclass(frozen=True)
class Mapping:
    """A parsed mapping file: per section, quantity -> :class:`ColumnSpec`.

    Parameters
    ----------
    path : Path or None
        Where it was read from (for error messages); None for the empty mapping.
    sections : dict
        ``{"points"|"daq"|"analyzer"|"log": {quantity: ColumnSpec}}``.
    skip_lines : dict
        ``{section: lines to skip before the file's header}`` (absent: 0).
    """

    path: Path | None = None
    sections: dict[str, dict[str, ColumnSpec]] = field(default_factory=dict)
    skip_lines: dict[str, int] = field(default_factory=dict)

    def section(self, name: str) -> dict[str, ColumnSpec]:
        """Entries of one section (empty when the mapping does not mention it)."""
        return self.sections.get(name, {})

    def skip(self, name: str) -> int:
        """Lines to skip at the top of the file of section ``name`` before its header."""
        return self.skip_lines.get(name, 0)


EMPTY_MAPPING = Mapping()


def load_mapping(path: str | Path) -> Mapping:
    """Read and validate a TOML (``.toml``) or JSON (``.json``) mapping file.

    Raises
    ------
    InputError
        Unreadable file, unknown section or quantity, an entry without exactly one
        of ``column``/``sum``/``expr`` and a ``unit``, an expression syntax error
        (with its position), a bad ``skip_lines``, or an unknown unit.
    """
    path = Path(path)
    text = read_text(path, what="mapping file")
    if path.suffix.lower() == ".json":
        raw = parse_json(text, path, what="mapping file")
    else:
        raw = parse_toml(text, path, what="mapping file")
    if not isinstance(raw, dict):
        raise InputError(path, "a mapping file must be a table", expected="TOML or a JSON object")
    sections: dict[str, dict[str, ColumnSpec]] = {}
    skip: dict[str, int] = {}
    if "columns" in raw:
        sections["points"] = _parse_columns(path, "columns", raw["columns"], "points")
    if "skip_lines" in raw:
        skip["points"] = _parse_skip(path, "skip_lines", raw["skip_lines"])
    for name in STREAM_SECTIONS:
        if name not in raw:
            continue
        table = raw[name]
        if not isinstance(table, dict) or not set(table) <= {"columns", "skip_lines"}:
            raise InputError(path, f"section [{name}] may hold only [{name}.columns.*] tables "
                             "and skip_lines", column=name)
        if "columns" in table:
            sections[name] = _parse_columns(path, f"{name}.columns", table["columns"], name)
        if "skip_lines" in table:
            skip[name] = _parse_skip(path, f"{name}.skip_lines", table["skip_lines"])
    unknown = set(raw) - {"columns", "skip_lines", *STREAM_SECTIONS}
    if unknown:
        raise InputError(
            path, f"unknown mapping section(s) {sorted(unknown)}",
            expected="skip_lines, [columns.*], "
            + ", ".join(f"[{s}.columns.*]" for s in STREAM_SECTIONS),
        )
    return Mapping(path=path, sections=sections, skip_lines=skip)


def _parse_skip(path: Path, key: str, value: object) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= MAX_SKIP_LINES:
        raise InputError(path, f"bad value {value!r} for {key}", column=key,
                         expected=f"a whole number of lines from 0 to {MAX_SKIP_LINES}")
    return value


def _parse_columns(path: Path, where: str, table: object, section: str) -> dict[str, ColumnSpec]:
    if not isinstance(table, dict):
        raise InputError(path, f"[{where}] must be a table of quantities")
    out: dict[str, ColumnSpec] = {}
    for quantity, entry in table.items():
        key = f"{where}.{quantity}"
        if quantity not in SECTION_QUANTITIES[section]:
            raise InputError(
                path, f"unknown quantity [{key}]",
                expected="one of " + ", ".join(SECTION_QUANTITIES[section]),
            )
        if quantity == COUNTER:
            out[quantity] = _parse_counter(path, key, entry)
            continue
        sources = set(entry) & {"column", "sum", "expr"} if isinstance(entry, dict) else set()
        if (not isinstance(entry, dict) or len(sources) != 1
                or set(entry) != sources | {"unit"}):
            raise InputError(
                path, f"[{key}] must have a 'unit' and exactly one of 'column', 'sum', 'expr'",
                column=key, expected='column = "Name", sum = ["A", "B"] or '
                'expr = "{A} * {B}", and unit = "..."',
            )
        unit = entry["unit"]
        if not isinstance(unit, str):
            raise InputError(path, f"[{key}] unit must be a string", column=f"{key}.unit")
        spec = _parse_source(path, key, sources.pop(), entry, unit)
        if quantity != "n_samples" and unit_factor(QUANTITY_KIND[quantity], unit) is None:
            kind = QUANTITY_KIND[quantity]
            raise InputError(
                path, f"{unit_problem(kind, unit)} for {quantity}", column=f"{key}.unit",
                expected=ACCEPTED[kind],
            )
        out[quantity] = spec
    return out


def _parse_counter(path: Path, key: str, entry: object) -> ColumnSpec:
    """``[<section>.columns.sample_counter]``: ``column`` and ``rate_hz`` (rows per second)."""
    rate = entry.get("rate_hz") if isinstance(entry, dict) else None
    if (not isinstance(entry, dict) or set(entry) != {"column", "rate_hz"}
            or not isinstance(entry["column"], str) or not entry["column"].strip()
            or isinstance(rate, bool) or not isinstance(rate, int | float)
            or not (0 < rate < float("inf"))):
        raise InputError(path, f"[{key}] must have a 'column' and a positive 'rate_hz'",
                         column=key, expected='column = "Sample", rate_hz = 4.0 (the '
                         "sample rate of the rows the counter numbers within a time stamp)")
    return ColumnSpec(entry["column"], f"1/{float(rate):g} s", rate_hz=float(rate))


def _parse_source(path: Path, key: str, how: str, entry: dict, unit: str) -> ColumnSpec:
    value = entry[how]
    if how == "column":
        if not isinstance(value, str) or not value.strip():
            raise InputError(path, f"[{key}] column must be a column name", column=f"{key}.column")
        return ColumnSpec(value, unit)
    if how == "sum":
        if (not isinstance(value, list) or len(value) < 2
                or not all(isinstance(v, str) and v.strip() for v in value)):
            raise InputError(path, f"[{key}] sum must list two or more column names",
                             column=f"{key}.sum", expected='sum = ["P_1 [W]", "P_2 [W]"]')
        names = [v.strip() for v in value]
        return ColumnSpec(" + ".join(f"{{{n}}}" for n in names), unit, expr.sum_of(names))
    if not isinstance(value, str):
        raise InputError(path, f"[{key}] expr must be a string", column=f"{key}.expr")
    try:
        formula = expr.parse(value)
    except expr.ExprError as exc:
        raise InputError(
            path, f"[{key}] expr: {exc.problem} at position {exc.position + 1}:\n"
            + expr.pointer(value, exc.position), column=f"{key}.expr",
            expected="{column names} in braces, numbers, + - * / and parentheses",
        ) from exc
    if not expr.columns(formula):
        raise InputError(path, f"[{key}] expr names no column", column=f"{key}.expr",
                         expected="at least one {column name} in braces")
    return ColumnSpec(value.strip(), unit, formula)


@dataclass(frozen=True)
class ResolvedColumn:
    """Where a quantity sits in a file and how to convert it.

    Parameters
    ----------
    index : int
        0-based index of the column in the file (of the first column a
        combination reads).
    header : str
        The column's header as written (a combination: its expression text).
    unit : str
        The unit as written (or as the mapping says).
    factor : float
        Multiplier to our unit (1.0 for counts).
    formula : expr.Node or None
        A combination of columns (``sum``/``expr``); None for a single column.
    sources : tuple of (str, int)
        ``(name in the formula, column index)`` of every column a combination
        reads; ``((header, index),)`` for a single column.
    offset : float
        Added after the factor (a temperature in K to degC: -273.15); 0 otherwise.
    """

    index: int
    header: str
    unit: str
    factor: float
    formula: expr.Node | None = None
    sources: tuple[tuple[str, int], ...] = ()
    offset: float = 0.0

    @property
    def indices(self) -> tuple[int, ...]:
        """Every file column this quantity reads, sorted, unique."""
        return tuple(sorted({i for _, i in self.sources} | {self.index}))

    def values(self, column: Callable[[int], np.ndarray]) -> np.ndarray:
        """The quantity in our unit: ``column(index)`` gives a file column as float64.

        A single column is scaled by :attr:`factor`; a combination is evaluated
        first (non-finite results become NaN) and then scaled.
        """
        if self.formula is None:
            x = column(self.index)
        else:
            index = dict(self.sources)
            x = np.asarray(expr.evaluate(self.formula, lambda name: column(index[name])),
                           dtype=np.float64)
            x = np.where(np.isfinite(x), x, np.nan)
        x = x * self.factor if self.factor != 1.0 else x
        return x + self.offset if self.offset else x


def closest_columns(wanted: list[str], headers: list[str], limit: int = MAX_LISTED,
                    what: str = "columns") -> str:
    """The few headers most like any of ``wanted`` and the count of the rest (for messages).

    All headers are listed when there are at most ``limit`` of them; ``what``
    names them (``"columns"``, ``"groups"``).
    """
    if len(headers) <= limit:
        return f"one of the file's {what}: " + ", ".join(repr(h) for h in headers)
    scored: dict[str, float] = {}
    lower = {h: split_header(h)[0].lower() for h in headers}
    for w in wanted:
        wl = split_header(w)[0].lower()
        for h in headers:
            ratio = max(difflib.SequenceMatcher(None, wl, lower[h]).ratio(),
                        difflib.SequenceMatcher(None, w.lower(), h.lower()).ratio())
            scored[h] = max(scored.get(h, 0.0), ratio)
    best = sorted(headers, key=lambda h: -scored[h])[:limit]
    return (f"closest of the file's {len(headers)} {what}: "
            + ", ".join(repr(h) for h in best) + f" (and {len(headers) - len(best)} more)")


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
        A key of :data:`SECTION_QUANTITIES` (``"daq"``, ``"analyzer"``,
        ``"log"``, ``"points"``).
    required, optional : tuple of str
        Quantities that must be found / may be found. ``p_mech`` is found only
        when the mapping names it.
    mapping : Mapping
        Explicit columns and combinations; they win over aliases.
    header_line : int, optional
        1-based line of the names row.

    Returns
    -------
    dict
        quantity -> :class:`ResolvedColumn`.

    Raises
    ------
    InputError
        A mapped column that does not exist (names the mapping file and the
        closest columns), a missing required column, a column whose unit is
        missing or unknown, or one column taken for two quantities.
    """
    stripped = [h.strip() for h in headers]
    bare = [split_header(h)[0].lower() for h in stripped]
    found: dict[str, ResolvedColumn] = {}
    for quantity, spec in mapping.section(section).items():
        if quantity in required + optional:
            found[quantity] = _mapped_column(path, stripped, bare, quantity, spec, mapping,
                                             _header_hint(found, header_line, section))
    for quantity in required + optional:
        if quantity in found or quantity not in ALIASES:
            continue
        idx = _alias_column(bare, ALIASES[quantity])
        if idx is None:
            if quantity in required:
                raise InputError(
                    path, f"missing column for {quantity}" + _header_hint(found, header_line,
                                                                          section),
                    line=header_line, column=quantity,
                    expected=f"a column named like {ALIASES[quantity][0].title()!r} with a unit, "
                    f"or a mapping entry [{section}.columns.{quantity}]; "
                    + closest_columns(list(ALIASES[quantity]), stripped),
                )
            continue
        found[quantity] = _aliased_column(path, stripped, units_row, quantity, idx, header_line)
    _check_distinct(path, mapping, found)
    return found


def _mapped_column(path: Path, stripped: list[str], bare: list[str], quantity: str, spec,
                   mapping: Mapping, hint: str) -> ResolvedColumn:
    """The file column (or columns of a combination) the mapping names for ``quantity``;
    ``hint``: what to add to the error when one is missing (:func:`_header_hint`)."""
    factor = (1.0 if quantity == "n_samples" else 1.0 / spec.rate_hz if quantity == COUNTER
              else unit_factor(QUANTITY_KIND[quantity], spec.unit))
    names = ([c.name for c in expr.columns(spec.formula)] if spec.formula is not None
             else [spec.column])
    sources = []
    for name in names:
        idx = _find_mapped(stripped, bare, name)
        if idx is None:
            where = "" if spec.formula is None else f" in {spec.column!r}"
            raise InputError(
                mapping.path, f"mapping names column {name!r} for {quantity}{where}, "
                f"but {path.name} has no such column" + hint, column=name,
                expected=closest_columns([name], stripped),
            )
        sources.append((name, idx))
    header = stripped[sources[0][1]] if spec.formula is None else spec.column
    offset = unit_offset(QUANTITY_KIND[quantity], spec.unit) if quantity in QUANTITY_KIND else 0.0
    return ResolvedColumn(sources[0][1], header, spec.unit, float(factor), spec.formula,
                          tuple(sources), offset)


def _aliased_column(path: Path, stripped: list[str], units_row: list[str] | None,
                    quantity: str, idx: int, header_line: int | None) -> ResolvedColumn:
    """Column ``idx``, found by alias, for ``quantity``, its unit from its name or the units
    row (InputError when missing or unknown)."""
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
            path, f"{unit_problem(kind, unit)} for {quantity}", line=header_line,
            column=stripped[idx], expected=ACCEPTED[kind],
        )
    return ResolvedColumn(idx, stripped[idx], unit, factor, sources=((stripped[idx], idx),),
                          offset=unit_offset(kind, unit))


def _alias_column(bare: list[str], aliases: tuple[str, ...]) -> int | None:
    """The column an alias names: the first alias (in the list's order) that a column's
    bare name equals; a weak alias (:data:`WEAK_ALIASES`) only when one column has it."""
    for alias in aliases:
        hits = [i for i, b in enumerate(bare) if b == alias]
        if hits and (alias not in WEAK_ALIASES or len(hits) == 1):
            return hits[0]
    return None


def _header_hint(found: dict, header_line: int | None, section: str) -> str:
    """When nothing of the names row matched, it may be a title or date line above it."""
    if found or header_line is None:
        return ""
    key = "skip_lines" if section == "points" else f"[{section}] skip_lines"
    return (f" (the column row read is line {header_line}; if lines above the real column row "
            f"hold a title or a date, skip them with {key} = N in the mapping file)")


def _check_distinct(path: Path, mapping: Mapping, found: dict[str, ResolvedColumn]) -> None:
    """Refuse one column (or one combination) taken for two quantities."""
    seen: dict[tuple, str] = {}
    for quantity, r in found.items():
        key = (r.header, r.indices) if r.formula is not None else (None, (r.index,))
        if key in seen:
            raise InputError(
                mapping.path or path, f"column {r.header!r} of {path.name} is taken for both "
                f"{seen[key]} and {quantity}", column=r.header,
                expected="a different column for each quantity (check the mapping)",
            )
        seen[key] = quantity


def _find_mapped(stripped: list[str], bare: list[str], column: str) -> int | None:
    """Index of a mapped column: the exact header first, then the header without regard to
    case and spacing, then the name without its unit."""
    if column in stripped:
        return stripped.index(column)
    squeeze = " ".join(column.split()).lower()
    loose = [" ".join(h.split()).lower() for h in stripped]
    if squeeze in loose:
        return loose.index(squeeze)
    return bare.index(squeeze) if squeeze in bare else None
