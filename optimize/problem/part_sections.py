"""The system file's sections of further parts: a part with inputs of its own is its
module, one line in :data:`PART_SECTIONS` and its test (:mod:`optimize.problem.part`).

This module imports nothing heavy: the system file's reader takes the table from here.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

#: the system file's sections of the parts beyond the kite's own (whose inputs are the
#: file's required sections), by section name: each a declared section
#: (:mod:`kernel.sections`) whose ``part(dae, scales)`` makes its part. A system file that
#: has the section flies the part, after the kite's own parts.
PART_SECTIONS: dict[str, type] = {}


def section_parts(inputs: Iterable[Any], dae: Any, scales: Any) -> tuple[Any, ...]:
    """The parts of a system file's part sections (``System.part_inputs``: the sections of
    :data:`PART_SECTIONS` the file gives, in that table's order); ``dae`` the kite's
    :class:`optimize.model.kite_model.KiteDae`, ``scales`` the system's
    :class:`optimize.problem.scaling.Scales`."""
    return tuple(section.part(dae, scales) for section in inputs)
