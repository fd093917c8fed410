"""Short text and HTML views of a result object, for the Python prompt and notebooks.

A result names what it holds as ``(label, value)`` pairs; :func:`text_view` makes its
``__repr__`` (one line per pair, at most :data:`MAX_REPR_CHARS` characters) and
:func:`html_view` its ``_repr_html_`` (a table, with any frames shown beneath it).
"""

from __future__ import annotations

import html
from collections.abc import Iterable

#: the longest ``repr`` of a result [characters]
MAX_REPR_CHARS = 1000


def text_view(name: str, rows: Iterable[tuple[str, object]]) -> str:
    """``name`` and one indented ``label: value`` line per row, cut to :data:`MAX_REPR_CHARS`.

    Parameters
    ----------
    name : str
        What the object is (its class name and a few words).
    rows : iterable of (str, object)
        Labels and values; each value is shown by ``str`` on one line.
    """
    lines = [name] + [f"  {label}: {_one_line(value)}" for label, value in rows]
    text = "\n".join(lines)
    if len(text) <= MAX_REPR_CHARS:
        return text
    cut = text[: MAX_REPR_CHARS - 30].rsplit("\n", 1)[0]
    return cut + f"\n  ... ({len(lines) - cut.count(chr(10)) - 1} more lines)"


def html_view(name: str, rows: Iterable[tuple[str, object]],
              frames: Iterable[tuple[str, object]] = ()) -> str:
    """An HTML table of the rows under a caption, then each ``(title, DataFrame)`` of
    ``frames`` as a table (at most 20 rows each); every string is escaped."""
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(label)}</th>"
                   f"<td style='text-align:left'>{html.escape(_one_line(value))}</td></tr>"
                   for label, value in rows)
    parts = [f"<table><caption style='text-align:left'><b>{html.escape(name)}</b></caption>"
             f"{body}</table>"]
    for title, frame in frames:
        if frame is not None:
            parts.append(f"<p><b>{html.escape(title)}</b></p>"
                         + frame.to_html(max_rows=20, escape=True, index=False))
    return "\n".join(parts)


def _one_line(value: object, width: int = 160) -> str:
    text = " ".join(str(value).split())
    return text if len(text) <= width else text[: width - 3] + "..."
