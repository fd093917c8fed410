"""drivebench from Python: each stage of the ``bench`` pipeline as one function that
returns a typed result and writes the stage's files (docs/python_api.md).

    >>> import drivebench as db
    >>> points = db.ingest(["raw_measurements"], store="bench_store").points  # doctest: +SKIP
    >>> model = db.fit("bench_store", out="fit_out")                     # doctest: +SKIP

The functions live in :mod:`drivebench.api`; their grouped options are frozen dataclasses
(:class:`WindGrid`, :class:`SolverChoice`, :class:`Execution`, :class:`SiteSpec`,
:class:`RefineOptions`, :class:`SizingGrid`, :class:`RatingOverrides`, :class:`ExportOptions`
with its :class:`BenchFrame`), the same objects
the ``bench`` commands build from their options.
"""

from importlib import metadata

from bench.cycle_profile import BenchFrame
from drivebench.api import (
    AepResult,
    Execution,
    ExportOptions,
    Ingested,
    RatingOverrides,
    RefineOptions,
    SiteSpec,
    SizeResult,
    SizingGrid,
    SolverChoice,
    Sweep,
    WindGrid,
    aep,
    cycle_export,
    cycle_verify,
    fit,
    ingest,
    optimize,
    size,
)
from drivebench.plots import plot_efficiency_map
from reports.plots import plot_aep, plot_cycle, plot_power_curves

#: the installed distribution's version, as ``bench --version`` prints it
__version__ = metadata.version("drivebench")

__all__ = ["AepResult", "BenchFrame", "Execution", "ExportOptions", "Ingested",
           "RatingOverrides", "RefineOptions", "SiteSpec", "SizeResult", "SizingGrid",
           "SolverChoice", "Sweep", "WindGrid", "aep", "cycle_export", "cycle_verify", "fit",
           "ingest", "optimize", "plot_aep", "plot_cycle", "plot_efficiency_map",
           "plot_power_curves", "size"]
