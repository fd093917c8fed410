"""The store's readers, generation commit, lock and cleanup (bench/store/)."""

from __future__ import annotations

import json
import math
import os
from datetime import date

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from bench.store.lock import StoreBusy
from bench.store.manifest import empty_manifest, kind_files, read_manifest
from bench.store.read import consistent_read, read_points, read_rejected
from bench.store.schema import POINTS_SCHEMA, REJECTED_SCHEMA, SCHEMA_VERSION
from bench.store.writer import StoreWriter
from kernel.errors import InputError


def _points(sid: str, n: int) -> pa.Table:
    cols = {f.name: [0.0] * n for f in POINTS_SCHEMA if f.type == pa.float64()}
    cols.update(session_id=[sid] * n, point_id=list(range(n)), mode=["motor"] * n,
                quadrant=["motor"] * n, source=["timeseries"] * n, n_samples=[1] * n)
    return pa.table(cols, schema=POINTS_SCHEMA)


def _commit(store, sid, n, entry=None):
    with StoreWriter(store) as w:
        staged = {}
        for kind, table in (("points", _points(sid, n)),
                            ("rejected", REJECTED_SCHEMA.empty_table())):
            staged[kind] = w.stage / f"{sid}.{kind}.parquet"
            pq.write_table(table, staged[kind])
        w.commit({sid: staged}, {sid: entry if entry is not None else {"n_points": n}})


def test_empty_store_reads_empty(tmp_path):
    assert read_manifest(tmp_path / "nope") == empty_manifest()
    pts = read_points(tmp_path / "nope")
    assert len(pts) == 0 and list(pts.columns) == POINTS_SCHEMA.names


def test_foreign_manifest_is_rejected(tmp_path):
    (tmp_path / "manifest.json").write_text(json.dumps({"schema": "other"}))
    with pytest.raises(InputError, match="not a drivebench store manifest"):
        read_manifest(tmp_path)


def test_commit_writes_a_generation_and_merges_the_manifest(tmp_path):
    store = tmp_path / "store"
    _commit(store, "b", 2)
    _commit(store, "a", 3)
    man = read_manifest(store)
    assert list(man["sessions"]) == ["a", "b"]  # merged, sorted
    assert man["generation"] == "gen-000002"
    assert len(read_points(store)) == 5
    # one generation left, nothing staged; the kept session is a hard link, not a copy
    assert sorted(p.name for p in store.iterdir()) == [".lock", "gen-000002", "manifest.json"]
    assert os.stat(kind_files(store, "points")["b"]).st_nlink == 1  # old generation removed
    assert set(kind_files(store, "samples")) == set()


def test_unlisted_files_are_never_read(tmp_path):
    """A generation an interrupted ingest left (not named by the manifest) is invisible."""
    store = tmp_path / "store"
    _commit(store, "a", 3)
    stray = store / "gen-000007" / "points"
    stray.mkdir(parents=True)
    pq.write_table(_points("zz", 4), stray / "zz.parquet")
    (store / ".staging-x").mkdir()
    assert len(read_points(store)) == 3
    _commit(store, "b", 1)  # the next writer cleans the leftovers up
    assert sorted(p.name for p in store.iterdir()) == [".lock", "gen-000002", "manifest.json"]
    assert sorted(read_points(store)["session_id"].unique()) == ["a", "b"]


def test_failed_writer_removes_a_store_it_created(tmp_path):
    store = tmp_path / "new"
    with pytest.raises(RuntimeError), StoreWriter(store):
        raise RuntimeError("boom")
    assert not store.exists()
    store.mkdir()
    (store / "keep.txt").write_text("x")
    with pytest.raises(RuntimeError), StoreWriter(store):
        raise RuntimeError("boom")
    assert sorted(p.name for p in store.iterdir()) == [".lock", "keep.txt"]


def test_nan_or_date_in_an_entry(tmp_path):
    """NaN never reaches manifest.json (not JSON); a TOML date is stored as ISO text."""
    store = tmp_path / "store"
    _commit(store, "a", 1, {"metadata": {"date": date(2013, 4, 17)}})
    assert read_manifest(store)["sessions"]["a"]["metadata"]["date"] == "2013-04-17"
    before = (store / "manifest.json").read_bytes()
    with pytest.raises(InputError, match="cannot be stored"):
        _commit(store, "b", 1, {"clock_offset_s": math.nan})
    assert (store / "manifest.json").read_bytes() == before
    assert list(read_manifest(store)["sessions"]) == ["a"]


def test_second_writer_stops_or_waits(tmp_path):
    store = tmp_path / "store"
    _commit(store, "a", 1)
    messages = []
    with StoreWriter(store):
        with pytest.raises(StoreBusy, match=f"pid {os.getpid()}"):
            with StoreWriter(store, wait=False):
                pass
    with StoreWriter(store, wait=False, notify=messages.append):
        pass
    assert messages == []


def test_version_1_store_is_read_and_migrated(tmp_path):
    store = tmp_path / "store"
    (store / "points").mkdir(parents=True)
    pq.write_table(_points("old", 2), store / "points" / "old.parquet")
    pq.write_table(_points("gone", 9), store / "points" / "gone.parquet")  # not listed
    (store / "manifest.json").write_text(json.dumps(
        {"schema": "drivebench.store", "schema_version": 1, "sessions": {"old": {}}}))
    assert len(read_points(store)) == 2 and len(read_rejected(store)) == 0
    _commit(store, "new", 1)
    assert not (store / "points").exists()
    assert sorted(read_points(store)["session_id"].unique()) == ["new", "old"]
    assert read_manifest(store)["schema_version"] == SCHEMA_VERSION


def test_reader_starts_over_when_a_writer_removes_its_generation(tmp_path):
    """A reader that read the old manifest, then lost the old generation to a writer's
    cleanup, re-reads the manifest and returns the new store (never a mix, no error)."""
    store = tmp_path / "store"
    _commit(store, "a", 3)
    calls = []

    def read(manifest):
        calls.append(manifest["generation"])
        paths = kind_files(store, "points", manifest)
        if len(calls) == 1:
            _commit(store, "b", 2)  # a writer switches generations under the reader
        return sum(pq.read_metadata(p).num_rows for p in paths.values())

    assert consistent_read(store, read) == 5
    assert calls == ["gen-000001", "gen-000002"]


def test_missing_listed_file_is_a_damaged_store(tmp_path):
    store = tmp_path / "store"
    _commit(store, "a", 3)
    kind_files(store, "points")["a"].unlink()
    with pytest.raises(InputError, match="damaged store"):
        read_points(store)
