"""Matplotlib figures as inline SVG for the HTML report (no files, no network).

Every figure is drawn on a bare :class:`matplotlib.figure.Figure` (no pyplot
state, Agg for rasterized parts) and serialized to SVG text that the template
inlines. Matplotlib escapes ``<``, ``>`` and ``&`` in SVG text and comments,
so labels taken from metadata (session ids) cannot inject markup; the SVG is
then marked safe for Jinja2. Each figure gets its own hash salt so the element
ids of two inline SVGs never collide in one HTML page.
"""

from __future__ import annotations

import io
import re

import matplotlib

matplotlib.use("Agg")

from markupsafe import Markup  # noqa: E402  (after selecting the backend)
from matplotlib.figure import Figure  # noqa: E402

from kernel.figure_text import fit_text  # noqa: E402

_PROLOGUE = re.compile(r"^.*?(?=<svg)", re.DOTALL)
_METADATA = re.compile(r"<metadata>.*?</metadata>\s*", re.DOTALL)


def new_figure(width_in: float = 7.0, height_in: float = 4.2) -> Figure:
    """A fresh figure of ``width_in`` x ``height_in`` [inch], constrained layout."""
    return Figure(figsize=(width_in, height_in), layout="constrained")


def to_svg(fig: Figure, name: str) -> Markup:
    """Serialize ``fig`` to inline SVG markup.

    Parameters
    ----------
    fig : Figure
        The figure; it is not reused afterwards.
    name : str
        A name unique within the report (our own constant, never metadata); it
        salts the SVG element ids and becomes the ``<svg>`` element's id.

    Returns
    -------
    Markup
        ``<svg ...>...</svg>`` without XML prologue, doctype and the RDF
        ``<metadata>`` block (creator credits), safe to inline.
    """
    fit_text(fig)  # no text beyond the figure's edges
    buf = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": name, "svg.fonttype": "none"}):
        fig.savefig(buf, format="svg", metadata={"Date": None}, dpi=110)
    text = _METADATA.sub("", _PROLOGUE.sub("", buf.getvalue(), count=1), count=1)
    text = text.replace("<svg ", f'<svg id="fig-{name}" role="img" ', 1)
    return Markup(text)
