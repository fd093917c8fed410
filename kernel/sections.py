"""A section of a TOML input file, declared once: a frozen dataclass whose fields carry
their unit (the name's suffix, :func:`kernel.units.unit_of`), range, default, source and
a one-line doc; one reader builds it from the file's table; one writer renders its keys
as the Markdown table of the docs.

A section is a frozen, keyword-only dataclass whose fields are made by :func:`number`,
:func:`integer`, :func:`text`, :func:`flag` or :func:`numbers`
(``default=None``: optional, absent is ``None``; no default: required); a field made by
:func:`group` holds a parameter set whose fields are keys of the same table (the kite's
aerodynamic coefficients). Checks that involve several keys are the section's
``problems()`` method: ``(key, problem, expected)`` for each, read after every key is.

    @dataclass(frozen=True, kw_only=True)
    class WinchSection:
        drum_radius_m: float = number("drum radius", lo=0)

    winch = read_section(WinchSection, table, path, "winch")

Every error is an :class:`kernel.errors.InputError` naming the file and ``[section]
key`` with what was expected (the range and the unit).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import MISSING, dataclass
from typing import Any

from kernel.errors import InputError
from kernel.units import unit_of

#: the field metadata's key of a :class:`Key`
KEY = "section_key"
#: what each kind of key reads, in words (the error's ``expected`` without a range)
KIND_WORDS = {
    "number": "a number", "integer": "an integer", "text": "a string", "flag": "true or false",
    "numbers": "a list of at least two finite numbers",
    "coefficient": "a finite number, or a list of 1 to 8 finite numbers (the coefficients "
                   "of 1, alpha, alpha^2, ... with alpha in rad)",
}


def _number(value: Any) -> bool:
    """A finite int or float (not a bool)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class Key:
    """How one key of a section is read and documented.

    Attributes
    ----------
    doc : str
        What it is, in one line (Markdown; the docs' table shows it).
    kind : str
        One of :data:`KIND_WORDS`.
    lo, hi : float or None
        The range of a number or an integer (None: open that side).
    lo_strict, hi_strict : bool
        Whether the value must be strictly above ``lo`` / below ``hi``.
    choices : tuple of str
        The allowed strings of a text key (empty: any).
    source : str
        Where the range or the default comes from (a public source), when not obvious.
    absent : str
        What an optional key's absence means, when more than "not stated".
    bound : str
        The name the summary's ``active_bounds`` reports an optimum on this key's bound
        by (docs/schemas.md §5), when the key is one bound of the OCP; else empty.
    """

    doc: str
    kind: str
    lo: float | None = None
    hi: float | None = None
    lo_strict: bool = True
    hi_strict: bool = False
    choices: tuple[str, ...] = ()
    source: str = ""
    absent: str = ""
    bound: str = ""

    def range_text(self) -> str:
        """The range in words: ``> 0``, ``>= 0``, ``1 to 100``, ``-273.15 < x <= 300``."""
        lo = None if self.lo is None else f"{self.lo:g}"
        hi = None if self.hi is None else f"{self.hi:g}"
        if lo is not None and hi is not None:
            if not self.lo_strict and not self.hi_strict:
                return f"{lo} to {hi}"
            return (f"{lo} {'<' if self.lo_strict else '<='} x "
                    f"{'<' if self.hi_strict else '<='} {hi}")
        if lo is not None:
            return f"{'>' if self.lo_strict else '>='} {lo}"
        if hi is not None:
            return f"{'<' if self.hi_strict else '<='} {hi}"
        return ", ".join(f'"{c}"' for c in self.choices)

    def expected(self, unit: str = "") -> str:
        """What the key takes, in words, with its range and unit."""
        words = KIND_WORDS[self.kind]
        if self.choices:
            return "one of " + ", ".join(self.choices)
        rng = self.range_text()
        if not rng:
            return words
        if self.lo is not None and self.hi is not None:
            rng = (f"from {self.lo:g} to {self.hi:g}" if not (self.lo_strict or self.hi_strict)
                   else f"{'>' if self.lo_strict else '>='} {self.lo:g} and "
                        f"{'<' if self.hi_strict else '<='} {self.hi:g}")
        return f"{words} {rng}" + (f" {unit}" if unit else "")

    def in_range(self, value: float) -> bool:
        """Whether ``value`` lies in the range."""
        if self.lo is not None and (value <= self.lo if self.lo_strict else value < self.lo):
            return False
        return not (self.hi is not None and (value >= self.hi if self.hi_strict
                                             else value > self.hi))


def _field(key: Key, default: Any) -> Any:
    return dataclasses.field(default=default, metadata={KEY: key})


def number(doc: str, *, lo: float | None = None, hi: float | None = None,
           lo_strict: bool = True, hi_strict: bool = False, default: Any = MISSING,
           source: str = "", absent: str = "", bound: str = "") -> Any:
    """A finite number in a range (a float field); ``bound``: the name of the OCP's bound it
    is (:attr:`Key.bound`)."""
    return _field(Key(doc, "number", lo, hi, lo_strict, hi_strict, source=source,
                      absent=absent, bound=bound), default)


def integer(doc: str, *, lo: int, hi: int, default: Any = MISSING, source: str = "",
            absent: str = "") -> Any:
    """An integer from ``lo`` to ``hi`` (an int field)."""
    return _field(Key(doc, "integer", lo, hi, False, False, source=source, absent=absent),
                  default)


def text(doc: str, *, choices: tuple[str, ...] = (), default: Any = MISSING,
         source: str = "", absent: str = "") -> Any:
    """A string, one of ``choices`` when given (a str field)."""
    return _field(Key(doc, "text", choices=choices, source=source, absent=absent), default)


def flag(doc: str, *, default: bool = False) -> Any:
    """A boolean (a bool field)."""
    return _field(Key(doc, "flag"), default)


def numbers(doc: str, *, default: Any = MISSING, absent: str = "") -> Any:
    """A list of at least two finite numbers (a tuple field)."""
    return _field(Key(doc, "numbers", absent=absent), default)


@dataclass(frozen=True)
class Group:
    """A field holding a parameter set whose fields are keys of the same table.

    Attributes
    ----------
    cls : type
        The parameter set (a dataclass; each field a key of ``kind``).
    kind : str
        What each of its keys reads (one of :data:`KIND_WORDS`).
    optional : tuple of str
        Its keys a file may leave out (absent: the dataclass's default).
    doc : str
        What the keys are, in one line.
    """

    cls: type
    kind: str
    optional: tuple[str, ...]
    doc: str


def group(cls: type, *, kind: str, optional: tuple[str, ...] = (), doc: str) -> Any:
    """A field holding ``cls``, its fields keys of the same table (:class:`Group`)."""
    return dataclasses.field(metadata={KEY: Group(cls, kind, optional, doc)})


def keys(section: type) -> Iterator[tuple[str, Key]]:
    """``(name, key)`` of every key of ``section``, a group's in its place."""
    for f in dataclasses.fields(section):
        meta = f.metadata.get(KEY)
        if isinstance(meta, Key):
            yield f.name, meta
        elif isinstance(meta, Group):
            for g in dataclasses.fields(meta.cls):
                yield g.name, Key(meta.doc, meta.kind)


def bound_keys(section: Any) -> dict[str, str]:
    """``{bound: key}`` of the keys of ``section`` (a section or its class) that are one
    bound of the OCP each (:attr:`Key.bound`)."""
    return {meta.bound: name for name, meta in keys(type(section) if not isinstance(
        section, type) else section) if meta.bound}


def bound_values(section: Any) -> dict[str, Any]:
    """``{bound: value}`` of a section's keys that are one bound of the OCP each (the value
    as read, ``None`` when not stated)."""
    return {bound: getattr(section, name) for bound, name in bound_keys(section).items()}


class _Table:
    """One section's table of a file: pops keys, naming file, section and key in errors."""

    def __init__(self, path: Any, section: str, data: Any):
        if not isinstance(data, dict):
            raise InputError(path, f"[{section}]: not a table", expected=f"a [{section}] table")
        self.path, self.section, self.data = path, section, dict(data)

    def error(self, key: str, problem: str, expected: str) -> InputError:
        return InputError(self.path, f"[{self.section}] {key}: {problem}", expected=expected)

    def value(self, name: str, key: Key, default: Any) -> Any:
        """The key's value, checked (``default`` when absent and optional)."""
        if name not in self.data:
            if default is MISSING:
                raise self.error(name, "missing", KIND_WORDS[key.kind])
            return default
        value, unit = self.data.pop(name), unit_of(name)
        read = _READERS[key.kind](value, key)
        if read is None:
            raise self.error(name, f"{value!r} is not {KIND_WORDS[key.kind]}",
                             key.expected(unit))
        if key.choices and read not in key.choices:
            raise self.error(name, f"{value!r} is not allowed", key.expected())
        if key.kind in ("number", "integer") and not key.in_range(read):
            raise self.error(name, f"{value!r} is out of range", key.expected(unit))
        return read


def _read_number(value: Any, key: Key) -> float | None:
    return float(value) if _number(value) else None


def _read_integer(value: Any, key: Key) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _read_text(value: Any, key: Key) -> str | None:
    return value if isinstance(value, str) else None


def _read_flag(value: Any, key: Key) -> bool | None:
    return value if isinstance(value, bool) else None


def _read_numbers(value: Any, key: Key) -> tuple[float, ...] | None:
    ok = isinstance(value, list) and len(value) >= 2 and all(map(_number, value))
    return tuple(float(v) for v in value) if ok else None


def _read_coefficient(value: Any, key: Key) -> float | tuple[float, ...] | None:
    if _number(value):
        return float(value)
    ok = isinstance(value, list) and 1 <= len(value) <= 8 and all(map(_number, value))
    return tuple(float(v) for v in value) if ok else None


_READERS = {"number": _read_number, "integer": _read_integer, "text": _read_text,
            "flag": _read_flag, "numbers": _read_numbers, "coefficient": _read_coefficient}


def _build(section: type, table: _Table) -> Any:
    """``section`` from the keys of ``table`` it declares (popped), checked."""
    values: dict[str, Any] = {}
    for f in dataclasses.fields(section):
        meta = f.metadata.get(KEY)
        if isinstance(meta, Key):
            values[f.name] = table.value(f.name, meta, f.default)
        elif isinstance(meta, Group):
            given = {g.name: table.value(g.name, Key(meta.doc, meta.kind),
                                         None if g.name in meta.optional else MISSING)
                     for g in dataclasses.fields(meta.cls)}
            values[f.name] = meta.cls(**{k: v for k, v in given.items() if v is not None})
    built = section(**values)
    for key, problem, expected in built.problems() if hasattr(built, "problems") else ():
        raise table.error(key, problem, expected)
    return built


def read_section(section: type, data: Any, path: Any, name: str) -> Any:
    """Build ``section`` from the file's table ``data`` of section ``[name]``.

    Raises
    ------
    InputError
        Not a table; a key missing, of the wrong type, out of range or unknown; or a
        problem of the section's ``problems()`` (each naming the file and the key).
    """
    table = _Table(path, name, data)
    built = _build(section, table)
    if table.data:
        raise table.error(sorted(table.data)[0], "unknown key",
                          "only the keys of docs/system_file.md")
    return built


def key_table(section: type) -> str:
    """The Markdown table of ``section``'s keys: key, unit, range, default and meaning (a
    group's keys in one row)."""
    lines = ["| key | unit | range | default | meaning |", "|---|---|---|---|---|"]
    for f in dataclasses.fields(section):
        meta = f.metadata.get(KEY)
        if isinstance(meta, Group):
            names = [g.name for g in dataclasses.fields(meta.cls)]
            required = ", ".join(f"`{n}`" for n in names if n not in meta.optional)
            optional = ", ".join(f"`{n}`" for n in meta.optional)
            lines.append(f"| {required} | - | - | required | {_cell(meta.doc)} |")
            if optional:
                lines.append(f"| {optional} | - | - | optional: 0 | {_cell(meta.doc)} |")
        elif isinstance(meta, Key):
            lines.append(_key_row(f, meta))
    return "\n".join(lines) + "\n"


def _key_row(f: dataclasses.Field, key: Key) -> str:
    """One key's row of :func:`key_table`."""
    if f.default is MISSING:
        default = "required"
    elif f.default is None:
        default = "optional" + (f": {key.absent}" if key.absent else "")
    else:
        default = f"`{_toml(f.default)}`"
    meaning = key.doc + (f" (source: {key.source})" if key.source else "")
    rng = key.range_text() or ("any" if key.kind == "number" else "-")
    return (f"| `{f.name}` | {unit_of(f.name) or '-'} | {_cell(rng)} | "
            f"{_cell(default)} | {_cell(meaning)} |")


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    return f"{value:g}" if isinstance(value, float) else str(value)


def _cell(text: str) -> str:
    """Text for a Markdown table cell: a ``|`` escaped (one already escaped kept)."""
    return text.replace("\\|", "|").replace("|", "\\|")
