"""docs/system_file.md's key tables, rendered from the declared sections
(:data:`optimize.system.sections.SECTIONS`, :func:`kernel.sections.key_table`).

The page's prose is written by hand; each section's table of keys sits between
:data:`BEGIN` and :data:`END` and is generated: ``python -m optimize.system.system_doc
docs/system_file.md`` rewrites them in place, and ``tests/test_system_doc.py`` checks that
the page holds what this renders.
"""

from __future__ import annotations

import sys
from pathlib import Path

from kernel.files import read_text, write_text_atomic
from kernel.sections import key_table
from optimize.system.sections import SECTIONS

#: the line before a section's generated table (``{section}`` its name)
BEGIN = "<!-- the keys of [{section}], generated: python -m optimize.system.system_doc -->"
#: the line after it
END = "<!-- end of the generated keys -->"


def render(page: str, sections: dict[str, type] | None = None) -> str:
    """``page`` with the table of every section (default :data:`SECTIONS`) rendered
    between its markers.

    Raises
    ------
    ValueError
        A section without its markers on the page.
    """
    for name, cls in (SECTIONS if sections is None else sections).items():
        begin = BEGIN.format(section=name)
        start = page.find(begin)
        stop = page.find(END, start)
        if start < 0 or stop < 0:
            raise ValueError(f"no generated table of [{name}]: the page needs the lines "
                             f"{begin!r} and {END!r}")
        page = page[:start] + begin + "\n\n" + key_table(cls) + "\n" + page[stop:]
    return page


def main(argv: list[str]) -> int:
    """Rewrite the key tables of the page ``argv[0]`` in place."""
    path = Path(argv[0])
    write_text_atomic(path, render(read_text(path, what="system file documentation")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
