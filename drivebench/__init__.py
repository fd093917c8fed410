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
are imported when first used (:func:`__getattr__`): ``bench --help`` does not load the
solver.
"""

from __future__ import annotations

import importlib
from importlib import metadata

#: the installed distribution's version, as ``bench --version`` prints it
__version__ = metadata.version("drivebench")

#: public name -> the module that defines it
_HOMES = {
    **dict.fromkeys(("AepResult", "Execution", "ExportOptions", "Ingested", "RatingOverrides",
                     "RefineOptions", "SiteSpec", "SizeResult", "SizingGrid", "SolverChoice",
                     "Sweep", "WindGrid", "aep", "cycle_export", "cycle_verify", "fit",
                     "ingest", "optimize", "size"), "drivebench.api"),
    "BenchFrame": "bench.cycle_profile",
    "plot_efficiency_map": "drivebench.plots",
    **dict.fromkeys(("plot_aep", "plot_cycle", "plot_power_curves"), "reports.plots"),
}

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    """Import a public name from its module on first use (PEP 562)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'drivebench' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOMES[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
