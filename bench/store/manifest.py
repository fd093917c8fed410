"""The store's ``manifest.json``: reading it, the files it lists, its JSON text."""

from __future__ import annotations

from pathlib import Path

from bench.store.schema import GENERATION_RE, READABLE_VERSIONS, SCHEMA_NAME, SCHEMA_VERSION
from kernel.errors import InputError
from kernel.files import dumps_json, read_json


def empty_manifest() -> dict:
    """A manifest with no sessions and no generation."""
    return {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, "generation": None,
            "sessions": {}}


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
    manifest = read_json(path, what="store manifest")
    if (not isinstance(manifest, dict) or manifest.get("schema") != SCHEMA_NAME
            or manifest.get("schema_version") not in READABLE_VERSIONS
            or not isinstance(manifest.get("sessions"), dict)):
        raise InputError(path, "not a drivebench store manifest",
                         expected=f"schema {SCHEMA_NAME!r} version {SCHEMA_VERSION}")
    manifest.setdefault("generation", None)
    gen = manifest["generation"]
    if gen is not None and not (isinstance(gen, str) and GENERATION_RE.match(gen)):
        raise InputError(path, f"bad generation {gen!r}", column="generation",
                         expected="gen-<number>")
    return manifest


def listed_files(manifest: dict, kind: str) -> dict[str, str]:
    """session_id -> file of ``kind`` relative to the store, as the manifest lists it."""
    out = {}
    gen = manifest.get("generation")
    for sid, entry in sorted(manifest["sessions"].items()):
        files = entry.get("store_files") if isinstance(entry, dict) else None
        if gen is not None and isinstance(files, dict):
            if files.get(kind):
                out[sid] = f"{gen}/{files[kind]}"
        elif gen is None:  # schema_version 1: <store>/<kind>/<sid>.parquet when present
            out[sid] = f"{kind}/{sid}.parquet"
    return out


def kind_files(store_dir: str | Path, kind: str, manifest: dict | None = None) -> dict[str, Path]:
    """The files of one kind that the store's manifest lists, by session id (sorted).

    Parameters
    ----------
    store_dir : str or Path
        The store.
    kind : str
        ``"points"``, ``"samples"`` or ``"rejected"``.
    manifest : dict, optional
        A manifest already read (default: read it now).

    Returns
    -------
    dict
        session_id -> file path. Files of a generation the manifest does not name
        (left by an interrupted ingest) are never listed.
    """
    store = Path(store_dir)
    manifest = read_manifest(store) if manifest is None else manifest
    paths = {sid: store / rel for sid, rel in listed_files(manifest, kind).items()}
    if manifest.get("generation") is None:  # v1 stores: a session may lack a kind
        paths = {sid: p for sid, p in paths.items() if p.is_file()}
    return paths


def dumps(obj) -> str:
    """JSON text of a manifest: sorted keys, stable bytes, never NaN or Infinity.

    Raises
    ------
    ValueError
        A non-finite float anywhere in ``obj`` (JSON has none).
    """
    return dumps_json(obj, indent=1, sort_keys=True, non_finite="error")
