"""``bench ingest``: bench logs (DAQ + power analyzer, or point tables) into the Parquet store.

One module per concept: :mod:`units` (unit table), :mod:`mapping` (foreign column
names), :mod:`readers` (one reader per file format), :mod:`scrub` (invalid markers,
time and NaN-run checks), :mod:`align` (clock offset/drift and as-of join),
:mod:`steady` (steady-state windows and quadrants), :mod:`pipeline` (sessions,
orchestration) and :mod:`summary` (closing table).
"""
