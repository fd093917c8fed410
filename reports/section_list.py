"""The report's numbered sections, in order: one module ``reports.<anchor>_section`` each.

Headings, the navigation bar and every cross-reference ("the model of section 3") take
their numbers from :data:`SECTIONS`, so none of them can disagree with the order here.
"""

from __future__ import annotations

#: (anchor, title) of each section; its number is its position, from 1
SECTIONS = (
    ("campaign", "Bench campaign"),
    ("efficiency", "Efficiency map (paper Fig. 5)"),
    ("model", "Power model (paper Table I, eq. 4, Fig. 6)"),
    ("optimization", "Optimized pumping cycles"),
    ("energy", "Annual energy and drive sizing"),
    ("verification", "The optimal cycle flown on the bench"),
    ("provenance", "Provenance"),
)


def section_list() -> list[dict]:
    """The sections for the template: ``anchor``, ``number``, ``title`` and ``short`` (the
    title without its parenthesis, for the navigation)."""
    return [{"anchor": a, "number": n, "title": t, "short": t.split(" (")[0]}
            for n, (a, t) in enumerate(SECTIONS, 1)]


def section_name(anchor: str) -> str:
    """``"section N (short title)"`` of the section ``anchor``, for a cross-reference."""
    entry = next(s for s in section_list() if s["anchor"] == anchor)
    return f"section {entry['number']} ({entry['short'].lower()})"
