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

The package also holds the ``bench`` command line (:mod:`drivebench.cli`), so its names
are imported on first use (:mod:`kernel.lazy`): ``bench --help`` does not load the solver.
"""

from importlib import metadata

from kernel.lazy import lazy_names

#: the installed distribution's version, as ``bench --version`` prints it
__version__ = metadata.version("drivebench")

#: home module -> the public names it defines
LAZY_IMPORTS = {
    "drivebench.api": ("AepResult", "Execution", "ExportOptions", "Ingested", "RatingOverrides",
                       "RefineOptions", "SiteSpec", "SizeResult", "SizingGrid", "SolverChoice",
                       "Sweep", "WindGrid", "aep", "cycle_export", "cycle_verify", "fit",
                       "ingest", "optimize", "size"),
    "bench.cycle_profile": ("BenchFrame",),
    "drivebench.plots": ("plot_efficiency_map",),
    "energy.plots": ("plot_aep", "plot_power_curves"),
    "optimize.door": ("plot_cycle",),
}

__all__ = sorted(name for names in LAZY_IMPORTS.values() for name in names)
__getattr__, __dir__ = lazy_names(__name__, LAZY_IMPORTS)
