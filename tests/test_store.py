"""The store's readers, atomic commit and staging cleanup."""

from __future__ import annotations

import json

import pyarrow as pa
import pytest

from bench.errors import InputError
from bench.store import (
    POINTS_SCHEMA,
    REJECTED_SCHEMA,
    commit,
    empty_manifest,
    read_manifest,
    read_points,
    staging,
)


def _points(sid: str, n: int) -> pa.Table:
    cols = {f.name: [0.0] * n for f in POINTS_SCHEMA if f.type == pa.float64()}
    cols.update(session_id=[sid] * n, point_id=list(range(n)), mode=["motor"] * n,
                quadrant=["motor"] * n, source=["timeseries"] * n, n_samples=[1] * n)
    return pa.table(cols, schema=POINTS_SCHEMA)


def test_empty_store_reads_empty(tmp_path):
    assert read_manifest(tmp_path / "nope") == empty_manifest()
    pts = read_points(tmp_path / "nope")
    assert len(pts) == 0 and list(pts.columns) == POINTS_SCHEMA.names


def test_foreign_manifest_is_rejected(tmp_path):
    (tmp_path / "manifest.json").write_text(json.dumps({"schema": "other"}))
    with pytest.raises(InputError, match="not a drivebench store manifest"):
        read_manifest(tmp_path)


def test_commit_moves_files_and_merges_manifest(tmp_path):
    import pyarrow.parquet as pq

    store = tmp_path / "store"
    for sid, n in (("b", 2), ("a", 3)):
        with staging(store) as stage:
            staged = {}
            for kind, table in (("points", _points(sid, n)),
                                ("rejected", REJECTED_SCHEMA.empty_table())):
                staged[kind] = stage / f"{sid}.{kind}.parquet"
                pq.write_table(table, staged[kind])
            commit(store, {sid: staged}, {sid: {"n_points": n}})
        assert not list(store.glob(".staging-*"))  # scratch removed
    man = read_manifest(store)
    assert list(man["sessions"]) == ["a", "b"]  # merged, sorted
    assert len(read_points(store)) == 5
    assert not (store / "samples" / "a.parquet").exists()


def test_failed_staging_removes_a_store_it_created(tmp_path):
    store = tmp_path / "new"
    with pytest.raises(RuntimeError), staging(store):
        raise RuntimeError("boom")
    assert not store.exists()
    store.mkdir()
    (store / "keep.txt").write_text("x")
    with pytest.raises(RuntimeError), staging(store):
        raise RuntimeError("boom")
    assert [p.name for p in store.iterdir()] == ["keep.txt"]


def test_store_path_that_is_a_file(tmp_path):
    f = tmp_path / "store"
    f.write_text("not a store")
    with pytest.raises(InputError, match="the store is not a directory"):
        read_manifest(f)
