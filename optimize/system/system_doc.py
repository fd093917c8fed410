"""docs/system_file.md's key tables, rendered from the declared sections
(:data:`optimize.system.sections.SECTIONS`, :func:`kernel.sections.key_table`).

The page's prose is written by hand; each section's table of keys sits between
:data:`BEGIN` and :data:`END`, and the sections of further parts
(:data:`optimize.problem.part_sections.PART_SECTIONS`), each with its heading, meaning and
table, between :data:`PARTS` and :data:`END`; all of them are generated: ``python -m
optimize.system.system_doc docs/system_file.md`` rewrites them in place, and
``tests/test_system_doc.py`` checks that the page holds what this renders.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kernel.files import read_text, write_text_atomic
from kernel.sections import key_table
from optimize.problem.part_sections import PART_SECTIONS
from optimize.system.sections import SECTIONS

#: the line before a section's generated table (``{section}`` its name)
BEGIN = "<!-- the keys of [{section}], generated: python -m optimize.system.system_doc -->"
#: the line before the generated sections of further parts
PARTS = "<!-- the sections of further parts, generated: python -m optimize.system.system_doc -->"
#: the line after a generated block
END = "<!-- end of the generated keys -->"


def render(page: str, sections: dict[str, type] | None = None,
           parts: dict[str, type] | None = None) -> str:
    """``page`` with the table of every section (default :data:`SECTIONS`) and the sections
    of further parts (default :data:`PART_SECTIONS`) rendered between their markers.

    Raises
    ------
    ValueError
        A section, or the further parts, without its markers on the page.
    """
    for name, cls in (SECTIONS if sections is None else sections).items():
        page = _between(page, BEGIN.format(section=name), "\n" + key_table(cls))
    return _between(page, PARTS, parts_text(PART_SECTIONS if parts is None else parts))


def parts_text(parts: dict[str, type]) -> str:
    """Each part section's heading, meaning (its docstring's first paragraph) and table."""
    if not parts:
        return "\nNone is registered in this installation.\n"
    out = ""
    for name, cls in parts.items():
        meaning = " ".join((cls.__doc__ or "").strip().split("\n\n")[0].split())
        out += f"\n### `[{name}]` (optional)\n\n{meaning}\n\n{key_table(cls)}"
    return out


def _between(page: str, begin: str, body: str) -> str:
    """``page`` with ``body`` between the line ``begin`` and the next :data:`END`."""
    start = page.find(begin)
    stop = page.find(END, start)
    if start < 0 or stop < 0:
        raise ValueError(f"no generated block: the page needs the lines {begin!r} and "
                         f"{END!r}")
    return page[:start] + begin + "\n" + body + "\n" + page[stop:]


#: the page the generated blocks live in, in a checkout of the project
PAGE = Path(__file__).resolve().parents[2] / "docs" / "system_file.md"


def main(argv: list[str]) -> int:
    """Rewrite the key tables of the page ``argv[0]`` (default :data:`PAGE`) in place;
    exit 2 with a usage line when there is no such page."""
    parser = argparse.ArgumentParser(
        prog="python -m optimize.system.system_doc",
        description="Rewrite the generated key tables of the system-file documentation.")
    parser.add_argument("page", nargs="?", type=Path, default=PAGE,
                        help="the page to rewrite (default: docs/system_file.md of this "
                             "checkout)")
    path = parser.parse_args(argv).page
    if not path.is_file():
        parser.error(f"{path}: no such page (give the path of docs/system_file.md)")
    write_text_atomic(path, render(read_text(path, what="system file documentation")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
