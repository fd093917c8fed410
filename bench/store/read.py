"""Reading the store: the files the manifest lists, checked against its recorded sizes
and hashes, consistent while a writer switches generations.

A store written before generations (schema_version 1, files directly in
``<store>/points`` etc.) is still read.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pandas as pd

from bench.store.manifest import kind_files, read_manifest
from bench.store.schema import SCHEMAS
from kernel.errors import InputError
from kernel.files import raise_mismatches, recorded_mismatch

#: times a reader starts over when a writer removed a generation under it
READ_RETRIES = 5
#: what repairs a damaged store, said by every reader that finds one
STORE_REPAIR = ("run bench store check, then bench ingest of the damaged sessions' folders "
                "(it re-ingests them)")

T = TypeVar("T")


def consistent_read(store_dir: str | Path, read: Callable[[dict], T]) -> T:
    """Call ``read(manifest)`` on the current manifest; start over if a writer moved on.

    A writer removes the previous generation once the manifest names the new
    one, so a reader that loses a file under it reads the new manifest and
    starts again (at most :data:`READ_RETRIES` times).

    Raises
    ------
    InputError
        A file the manifest lists is missing while the manifest did not change
        (a damaged store), or the store kept changing.
    """
    for _ in range(READ_RETRIES):
        manifest = read_manifest(store_dir)
        try:
            return read(manifest)
        except FileNotFoundError as exc:
            if read_manifest(store_dir).get("generation") == manifest.get("generation"):
                raise InputError(exc.filename or store_dir,
                                 "a file the store manifest lists is missing (damaged store)",
                                 expected=STORE_REPAIR) from exc
    raise InputError(store_dir, f"the store changed {READ_RETRIES} times while being read",
                     expected="no ingest running into it")


def _mismatch(path: Path, data: bytes, entry: dict, kind: str) -> str | None:
    """How ``data`` differs from the size and hash the manifest records (None: as recorded)."""
    rec = (entry.get("store_checks") or {}).get(kind) if isinstance(entry, dict) else None
    if not isinstance(rec, dict):
        return None  # a store written before the manifest recorded its files' hashes
    return recorded_mismatch(path, rec, data)


def _raise_damaged(problems: list[tuple[Path, str]]) -> None:
    raise_mismatches(problems, "the store manifest: damaged store", STORE_REPAIR)


def read_listed_bytes(store_dir: str | Path, kind: str,
                      manifest: dict) -> dict[str, tuple[Path, bytes]]:
    """The bytes of the files of one kind the manifest lists, checked against its hashes.

    Raises
    ------
    FileNotFoundError
        A listed file is missing (:func:`consistent_read` tells a damaged store
        from a writer that moved on).
    InputError
        A file whose size or SHA-256 differs from the manifest's record.
    """
    out, problems = {}, []
    for sid, path in kind_files(store_dir, kind, manifest).items():
        data = path.read_bytes()
        problem = _mismatch(path, data, manifest["sessions"].get(sid), kind)
        if problem is not None:
            problems.append((path, problem))
        out[sid] = (path, data)
    _raise_damaged(problems)
    return out


def parse_parquet(path: Path, data: bytes) -> pd.DataFrame:
    """A store file's bytes as a frame; InputError naming the file when it is no Parquet."""
    try:
        return pd.read_parquet(io.BytesIO(data))
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        raise InputError(path, f"not a readable Parquet file ({exc}): damaged store",
                         expected=STORE_REPAIR) from exc


def _read_kind(store_dir: str | Path, kind: str) -> pd.DataFrame:
    def read(manifest: dict) -> pd.DataFrame:
        frames = [parse_parquet(p, data)
                  for p, data in read_listed_bytes(store_dir, kind, manifest).values()]
        if not frames:
            return SCHEMAS[kind].empty_table().to_pandas()
        return pd.concat(frames, ignore_index=True)

    return consistent_read(store_dir, read)


def read_points(store_dir: str | Path) -> pd.DataFrame:
    """All operating points of the store, one row each (docs/schemas.md section 2)."""
    return _read_kind(store_dir, "points")


def read_rejected(store_dir: str | Path) -> pd.DataFrame:
    """All rejected steady-state windows with their reasons."""
    return _read_kind(store_dir, "rejected")


def read_cycles(store_dir: str | Path) -> pd.DataFrame:
    """All kept cycles of the store's cycle-run sessions, one row each."""
    return _read_kind(store_dir, "cycles")


def read_samples(store_dir: str | Path, session_id: str) -> pd.DataFrame:
    """The aligned time series of one timeseries session."""
    def read(manifest: dict) -> pd.DataFrame:
        path = kind_files(store_dir, "samples", manifest).get(session_id)
        if path is None:
            raise InputError(Path(store_dir) / "manifest.json",
                             f"no samples for session {session_id!r}")
        data = path.read_bytes()
        problem = _mismatch(path, data, manifest["sessions"].get(session_id), "samples")
        _raise_damaged([] if problem is None else [(path, problem)])
        return parse_parquet(path, data)

    return consistent_read(store_dir, read)
