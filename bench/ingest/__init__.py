"""``bench ingest``: bench logs (DAQ + power analyzer, or point tables) into the Parquet store.

One module per concept: :mod:`units` (unit table), :mod:`mapping` (foreign column
names), :mod:`session` (``session.toml`` and discovery), :mod:`readers` (one
reader per file format), :mod:`scrub` (invalid markers, time and NaN-run checks),
:mod:`align` (clock offset/drift and as-of join), :mod:`steady` (steady-state
windows and quadrants), :mod:`timeseries` and :mod:`table` (one session of each
kind), :mod:`pipeline` (orchestration, idempotence, atomic commit),
:mod:`summary` (closing table) and :mod:`cli`. The store itself is the package :mod:`bench.store`.
"""
