"""The figures of the Python API that read a stage's folder: each draws into a matplotlib
``Axes`` (a new figure without one) with the report's own drawing code
(:mod:`optimize.plots`), so a notebook shows what the report shows."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd


def plot_efficiency_map(fit: str | Path | pd.DataFrame = "fit_out", ax: Any = None, *,
                        cycles: dict[str, pd.DataFrame] | None = None) -> Any:
    """The measured efficiency map (paper Fig. 5), with cycles over it (paper Fig. 9).

    Parameters
    ----------
    fit : path or DataFrame
        A ``bench fit`` output folder (its ``efficiency_map.parquet``, and the validity
        domain of its ``power_model.json``), or the map frame itself.
    ax : matplotlib Axes, optional
        Where to draw; default a new figure.
    cycles : dict, optional
        Scenario kind -> closed cycle (:meth:`Sweep.cycles`), drawn over the map.

    Returns
    -------
    matplotlib Axes
    """
    from fitting.fit_folder import MODEL_FILE, read_efficiency_map, read_power_model
    from optimize.door import plot_efficiency_map as draw

    domain = None
    if isinstance(fit, pd.DataFrame):
        frame = fit
    else:
        frame = read_efficiency_map(Path(fit))
        if (Path(fit) / MODEL_FILE).is_file():
            domain = read_power_model(Path(fit)).domain
    return draw(frame, ax, domain=domain, cycles=cycles)
