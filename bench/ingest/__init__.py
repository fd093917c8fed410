"""``bench ingest``: bench logs (DAQ + power analyzer, or point tables) into the Parquet store.

One module per concept:

- the session and its columns: :mod:`session` (``session.toml`` and discovery),
  :mod:`mapping` (foreign column names), :mod:`column_units` (the units a logged
  column may be in), :mod:`expr` (column expressions), :mod:`clock` (clock-time
  columns);
- reading files: :mod:`csv_layout` (sniffing a CSV), :mod:`csv_stream` (its rows in
  chunks), :mod:`daq_stream` (the DAQ stream, CSV or TDMS), :mod:`readers` (the
  analyzer record and the point table), :mod:`scrub` (invalid markers, time and
  NaN-run checks);
- one timeseries session: :mod:`timeseries` (its steps), :mod:`scan` (pass 1 over the
  stream), :mod:`bins` (bin sums), :mod:`tare` (the torque zero), :mod:`analyzer` and
  :mod:`align` (the analyzer on the DAQ clock), :mod:`steady` (steady-state windows
  and quadrants), :mod:`checks` (plausibility), :mod:`samples_file` (pass 2: the
  samples file, the windows' statistics), :mod:`drum_frame` (signs, gear);
- one point-table session: :mod:`table`;
- both: :mod:`store_tables` (what a session hands to the store: its tables),
  :mod:`pipeline` (orchestration, idempotence, atomic commit), :mod:`summary`
  (closing table) and :mod:`cli`.

The store itself is the package :mod:`bench.store`.
"""
