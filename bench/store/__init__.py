"""The Parquet store written by ``bench ingest`` (docs/schemas.md section 2).

Layout::

    <store>/manifest.json                     names the current generation
    <store>/.lock                             held by the one ingest writing
    <store>/gen-<n>/points/<session_id>.parquet
    <store>/gen-<n>/samples/<session_id>.parquet
    <store>/gen-<n>/rejected/<session_id>.parquet

A generation directory is written whole in ``<store>/.staging-*`` (new
sessions' files moved in, unchanged sessions' files hard-linked from the
current generation), renamed into place, and only then does ``manifest.json``
switch to it, by one atomic :func:`os.replace`. At every instant the manifest
names a complete generation: a reader sees the old store or the new one, never
a mix. Generations the manifest does not name and leftover staging folders are
removed by the next writer.

Modules, one concept each: :mod:`~bench.store.schema` (the Parquet schemas and
the layout's names), :mod:`~bench.store.manifest` (reading the manifest and the
files it lists), :mod:`~bench.store.read` (the checked readers
``read_points``, ``read_rejected``, ``read_samples``), :mod:`~bench.store.damage`
(``check_store``), :mod:`~bench.store.lock` (the one-writer lock),
:mod:`~bench.store.writer` (``StoreWriter``: scratch space, generation commit,
cleanup) and :mod:`~bench.store.cli` (``bench store check``).
"""
