"""drivebench from Python: each stage of the ``bench`` pipeline as one function that
returns a typed result and writes the stage's files (docs/python_api.md).

    >>> import drivebench as db
    >>> points = db.ingest(["raw_measurements"], store="bench_store").points  # doctest: +SKIP
    >>> model = db.fit("bench_store", out="fit_out")                     # doctest: +SKIP

The functions live in :mod:`drivebench.api`; their grouped options are frozen dataclasses
(:class:`WindGrid`, :class:`SolverChoice`, :class:`Execution`, :class:`SiteSpec`,
:class:`RefineOptions`, :class:`SizingGrid`, :class:`RatingOverrides`), the same objects
the ``bench`` commands build from their options.
"""

from drivebench.api import (
    AepResult,
    Execution,
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
    fit,
    ingest,
    optimize,
    size,
)

__all__ = ["AepResult", "Execution", "Ingested", "RatingOverrides", "RefineOptions", "SiteSpec",
           "SizeResult", "SizingGrid", "SolverChoice", "Sweep", "WindGrid", "aep", "fit",
           "ingest", "optimize", "size"]
