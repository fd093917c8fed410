"""The Parquet store written by ``bench ingest`` (docs/schemas.md section 2).

Layout::

    <store>/manifest.json
    <store>/points/<session_id>.parquet
    <store>/samples/<session_id>.parquet
    <store>/rejected/<session_id>.parquet

Writes are staged in ``<store>/.staging-*`` and only moved into place
(``os.replace``, same file system) once every session has been processed;
the manifest goes last, atomically. Readers: :func:`read_points`,
:func:`read_manifest`, :func:`read_rejected`, :func:`read_samples`.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pyarrow as pa

from bench.errors import InputError
from bench.files import write_text_atomic

SCHEMA_NAME = "drivebench.store"
SCHEMA_VERSION = 1
KINDS = ("points", "samples", "rejected")


def _f(name: str, typ: pa.DataType, unit: str | None = None) -> pa.Field:
    return pa.field(name, typ, metadata=None if unit is None else {"unit": unit})


POINTS_SCHEMA = pa.schema([
    _f("session_id", pa.string()),
    _f("point_id", pa.int32()),
    _f("mode", pa.string()),
    _f("quadrant", pa.string()),
    _f("source", pa.string()),
    _f("speed_rpm", pa.float64(), "rpm"),
    _f("torque_nm", pa.float64(), "N m"),
    _f("p_mech_w", pa.float64(), "W"),
    _f("p_elec_w", pa.float64(), "W"),
    _f("speed_rpm_std", pa.float64(), "rpm"),
    _f("torque_nm_std", pa.float64(), "N m"),
    _f("p_mech_w_std", pa.float64(), "W"),
    _f("p_elec_w_std", pa.float64(), "W"),
    _f("n_samples", pa.int32()),
    _f("t_start_s", pa.float64(), "s"),
    _f("t_end_s", pa.float64(), "s"),
])

SAMPLES_SCHEMA = pa.schema([
    _f("session_id", pa.dictionary(pa.int32(), pa.string())),
    _f("time_s", pa.float64(), "s"),
    _f("speed_rpm", pa.float64(), "rpm"),
    _f("torque_nm", pa.float64(), "N m"),
    _f("p_mech_w", pa.float64(), "W"),
    _f("p_elec_w", pa.float64(), "W"),
    _f("point_id", pa.int32()),
])

REJECTED_SCHEMA = pa.schema([
    _f("session_id", pa.string()),
    _f("t_start_s", pa.float64(), "s"),
    _f("t_end_s", pa.float64(), "s"),
    _f("reason", pa.string()),
])


def empty_manifest() -> dict:
    """A manifest with no sessions."""
    return {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, "sessions": {}}


def read_manifest(store_dir: str | Path) -> dict:
    """Read ``manifest.json`` (an empty manifest when the store does not exist yet).

    Raises
    ------
    InputError
        The file exists but is not a drivebench store manifest.
    """
    if Path(store_dir).exists() and not Path(store_dir).is_dir():
        raise InputError(store_dir, "the store is not a directory",
                         expected="a store directory (created when missing)")
    path = Path(store_dir) / "manifest.json"
    if not path.exists():
        return empty_manifest()
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(path, f"unreadable store manifest ({exc})") from exc
    if manifest.get("schema") != SCHEMA_NAME or manifest.get("schema_version") != SCHEMA_VERSION:
        raise InputError(path, "not a drivebench store manifest",
                         expected=f"schema {SCHEMA_NAME!r} version {SCHEMA_VERSION}")
    return manifest


def _read_dir(store_dir: str | Path, kind: str, schema: pa.Schema) -> pd.DataFrame:
    folder = Path(store_dir) / kind
    files = sorted(folder.glob("*.parquet")) if folder.is_dir() else []
    if not files:
        return schema.empty_table().to_pandas()
    return pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)


def read_points(store_dir: str | Path) -> pd.DataFrame:
    """All operating points of the store, one row each (docs/schemas.md section 2)."""
    return _read_dir(store_dir, "points", POINTS_SCHEMA)


def read_rejected(store_dir: str | Path) -> pd.DataFrame:
    """All rejected steady-state windows with their reasons."""
    return _read_dir(store_dir, "rejected", REJECTED_SCHEMA)


def read_samples(store_dir: str | Path, session_id: str) -> pd.DataFrame:
    """The aligned time series of one timeseries session."""
    path = Path(store_dir) / "samples" / f"{session_id}.parquet"
    if not path.exists():
        raise InputError(path, f"no samples for session {session_id!r}")
    return pd.read_parquet(path)


def write_json(obj: dict, path: Path) -> None:
    """Write JSON (sorted keys, stable bytes) atomically."""
    write_text_atomic(path, json.dumps(obj, indent=1, sort_keys=True) + "\n")


@contextmanager
def staging(store_dir: str | Path) -> Iterator[Path]:
    """A scratch directory inside the store; removed on exit, and so is a store it created.

    Everything an ingest writes goes here first, so a failure leaves the store
    exactly as it was.
    """
    store = Path(store_dir)
    created = not store.exists()
    store.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".staging-", dir=store))
    ok = False
    try:
        yield tmp
        ok = True
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if created and not ok:
            shutil.rmtree(store, ignore_errors=True)


def commit(
    store_dir: str | Path, staged: dict[str, dict[str, Path]], entries: dict[str, dict]
) -> None:
    """Move staged session files into place, then write the manifest last.

    Parameters
    ----------
    store_dir : str or Path
        The store.
    staged : dict
        session_id -> {kind: staged Parquet file}; kinds a session lacks are removed
        from the store (a session whose kind changed leaves nothing stale).
    entries : dict
        session_id -> manifest entry, merged into the existing manifest.
    """
    store = Path(store_dir)
    manifest = read_manifest(store)
    for kind in KINDS:
        (store / kind).mkdir(exist_ok=True)
    for sid, files in staged.items():
        for kind in KINDS:
            dest = store / kind / f"{sid}.parquet"
            if kind in files:
                os.replace(files[kind], dest)
            elif dest.exists():
                dest.unlink()
    manifest["sessions"].update(entries)
    manifest["sessions"] = dict(sorted(manifest["sessions"].items()))
    write_json(manifest, store / "manifest.json")
