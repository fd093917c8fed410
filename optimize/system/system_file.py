"""Reading a system file: every section's keys checked, then the whole system's plausibility.

:func:`load_system` reads and validates a file into a frozen
:class:`optimize.system.system.System`; every error (unknown or missing key, wrong
type, a value outside its range such as a negative mass, an inertia that is not positive
definite or a torque-speed table that is not monotone) is an
:class:`~kernel.errors.InputError` naming the file and the key. Each section's keys are
declared once (:mod:`optimize.system.sections`, docs/system_file.md) and read by the one
reader :func:`kernel.sections.read_section`.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from kernel.errors import InputError
from kernel.files import parse_toml, read_text
from kernel.sections import bound_keys, bound_values, read_section
from optimize.problem.part_sections import PART_SECTIONS
from optimize.system.plausibility import check_system
from optimize.system.sections import SECTIONS, BoundsSection, TetherSection
from optimize.system.system import System, shipped_system_path


def _check_sections(data: Any, path: str) -> None:
    """Every required section there, none unknown (a part's section is optional)."""
    if not isinstance(data, dict):
        raise InputError(path, "not a table of sections", expected="a TOML file")
    unknown = sorted(set(data) - set(SECTIONS) - set(PART_SECTIONS))
    if unknown:
        raise InputError(path, f"[{unknown[0]}]: unknown section",
                         expected="sections " + ", ".join(SECTIONS) + "".join(
                             f", [{name}] (optional)" for name in PART_SECTIONS))
    for s in SECTIONS:
        if s not in data:
            raise InputError(path, f"[{s}]: missing section",
                             expected="sections " + ", ".join(SECTIONS))


def _check_tension_range(path: str, tether: TetherSection, bounds: BoundsSection) -> None:
    """The tension floor below the tether-force limit (when both are given)."""
    top = [v for v in (tether.max_force_n, tether.working_load_n()) if v is not None]
    floor = bound_values(bounds)["tension_min"]
    if floor is not None and top and floor >= min(top):
        raise InputError(path, f"[bounds] {bound_keys(bounds)['tension_min']}: {floor:g} N is "
                         f"not below the tether-force limit {min(top):g} N",
                         expected="a tension floor below [tether] max_force_n (or the "
                         "line's working load)")


def system_from_dict(data: dict, path: str = "<system>", text: str = "") -> System:
    """Validate a parsed system file (see :func:`load_system`): each section by its reader,
    then the whole system's plausibility."""
    _check_sections(data, path)
    read = {name: read_section(cls, data[name], path, name) for name, cls in SECTIONS.items()}
    parts = tuple(read_section(cls, data[name], path, name)
                  for name, cls in PART_SECTIONS.items() if name in data)
    _check_tension_range(path, read["tether"], read["bounds"])
    canonical = json.dumps(data, sort_keys=True, separators=(",", ":"))
    head = read["system"]
    system = System(head.name, head.description, read["kite"], read["aero"], read["tether"],
                    read["winch"], read["drive"], read["wind"], read["bounds"], path, text,
                    hashlib.sha256(canonical.encode("utf-8")).hexdigest(), head.paper_system,
                    parts)
    check_system(system)  # well-formed is not enough: refuse what cannot fly, before any solve
    return system


def load_system(path: str | Path | None = None) -> System:
    """Read and validate a system file (default: the shipped ``highwind.toml``).

    Raises
    ------
    InputError
        File missing, not UTF-8 or not TOML, or any key wrong (named with the file).
    """
    path = Path(path) if path is not None else shipped_system_path()
    text = read_text(path, what="system file")
    return system_from_dict(parse_toml(text, path, what="system file"), str(path), text)
