"""Figure text that stays inside its figure: long titles, labels and legend entries are
wrapped to the figure's width before a figure is saved; labels from metadata made safe
(:func:`plain_label`), and the axes a plotting function draws on (:func:`new_axes`).

A centred title wider than its figure is cut at both ends in the saved file; constrained
layout makes room for more lines but does not break a line. :func:`fit_text` breaks every
text that would overflow, then lets the layout run again; :func:`overflowing_text` lists
what still overflows (the check the tests make over every figure).
"""

from __future__ import annotations

import textwrap
from typing import Any

from matplotlib.figure import Figure
from matplotlib.text import Text

#: share of the figure's width (height, for vertical text) a line may take
MAX_SHARE = 0.97


def _renderer(fig: Figure):
    """A renderer of ``fig`` after its layout has run as saving runs it (text extents are
    known then); nothing is rasterized."""
    if not hasattr(fig.canvas, "get_renderer"):
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    return fig.canvas.get_renderer()


def _texts(fig: Figure) -> list[Text]:
    """The texts a saved figure shows (tick labels beyond the axis' view are not drawn)."""
    hidden = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            pad = 1e-9 * max(1.0, abs(hi - lo))
            for tick in [*axis.get_major_ticks(), *axis.get_minor_ticks()]:
                if not lo - pad <= tick.get_loc() <= hi + pad:
                    hidden.update((id(tick.label1), id(tick.label2)))
    return [t for t in fig.findobj(Text)
            if t.get_visible() and t.get_text().strip() and id(t) not in hidden]


def _extent(text: Text, fig: Figure, renderer) -> tuple[float, float]:
    """(length of the text along its direction, the figure's length that way) [px]."""
    box = text.get_window_extent(renderer)
    vertical = abs(text.get_rotation() % 180 - 90) < 1
    return (box.height, fig.bbox.height) if vertical else (box.width, fig.bbox.width)


def fit_text(fig: Figure, passes: int = 3) -> Figure:
    """Wrap every text of ``fig`` longer than :data:`MAX_SHARE` of the figure (in its
    direction) at spaces, until none is or ``passes`` rounds have run; returns ``fig``.

    The layout it ends with is kept (the figure's layout engine is set to none), so a
    figure saved in several formats is laid out once: `bench fit` saves each figure as
    PNG and SVG, and its three figures took 2.35 s instead of 2.9 s."""
    for _ in range(passes):
        renderer, changed = _renderer(fig), False
        for text in _texts(fig):
            length, room = _extent(text, fig, renderer)
            if length <= MAX_SHARE * room:
                continue
            lines = text.get_text().split("\n")
            width = max(8, int(max(map(len, lines)) * MAX_SHARE * room / length))
            wrapped = "\n".join(textwrap.fill(line, width) for line in lines)
            if wrapped != text.get_text():
                text.set_text(wrapped)
                changed = True
        if not changed:
            break
    else:
        fig.draw_without_rendering()  # the layout of the last wrapped text
    fig.set_layout_engine("none")  # kept as found: each saved format is laid out alike
    return fig


def fit_title(ax) -> None:
    """Wrap the title of ``ax`` at spaces to :data:`MAX_SHARE` of the axes' width, so it
    stays over its own axes: inside the figure and off a neighbouring panel (a figure's
    layout may still change after; :func:`fit_text` checks the whole figure)."""
    for _ in range(3):
        renderer, title = _renderer(ax.figure), ax.title
        length, room = title.get_window_extent(renderer).width, ax.bbox.width
        if not title.get_text().strip() or length <= MAX_SHARE * room:
            return
        lines = title.get_text().split("\n")
        width = max(8, int(max(map(len, lines)) * MAX_SHARE * room / length))
        title.set_text("\n".join(textwrap.fill(line, width) for line in lines))


def overflowing_text(fig: Figure, tolerance_px: float = 1.0) -> list[str]:
    """The texts of ``fig`` (after layout) that reach beyond the figure's edges."""
    renderer = _renderer(fig)
    box = fig.bbox
    out = []
    for text in _texts(fig):
        b = text.get_window_extent(renderer)
        if (b.x0 < box.x0 - tolerance_px or b.x1 > box.x1 + tolerance_px
                or b.y0 < box.y0 - tolerance_px or b.y1 > box.y1 + tolerance_px):
            out.append(text.get_text())
    return out


def new_axes(ax: Any = None, size_in: tuple[float, float] = (7.0, 4.2)) -> Any:
    """``ax``, or the axes of a new pyplot figure of ``size_in`` [inch] (constrained layout)."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.figure(figsize=size_in, layout="constrained").add_subplot()


def plain_label(text: object) -> str:
    """A label made safe for matplotlib text: no mathtext, bounded length."""
    return str(text).replace("$", r"\$")[:60]
