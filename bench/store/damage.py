"""Damage check: is every file the manifest lists present, and as it records?"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pyarrow.parquet as pq

from bench.store.manifest import listed_files, read_manifest
from bench.store.schema import GENERATION_RE, KINDS, STAGING_PREFIX
from kernel.files import recorded_mismatch


@dataclass
class StoreDamage:
    """What :func:`check_store` found wrong with a store (empty: healthy).

    Parameters
    ----------
    sessions : dict
        session_id -> problems of its stored files (missing, size or hash differs,
        not a readable Parquet file), one line each.
    generation : str or None
        A problem of the generation the manifest names (its folder is missing).
    unnamed : list of str
        Generation folders the manifest does not name (left by an interrupted ingest,
        or the data of a hand-edited manifest).
    staging : list of str
        Staging folders left by an interrupted ingest.
    """

    sessions: dict[str, list[str]] = field(default_factory=dict)
    generation: str | None = None
    unnamed: list[str] = field(default_factory=list)
    staging: list[str] = field(default_factory=list)

    @property
    def damaged(self) -> bool:
        """True when a file the manifest lists cannot be trusted."""
        return bool(self.sessions) or self.generation is not None

    def lines(self) -> list[str]:
        """One line per problem, for people."""
        out = [] if self.generation is None else [self.generation]
        out += [f"session {sid!r}: {p}" for sid, ps in self.sessions.items() for p in ps]
        out += [f"{g}: a generation the manifest does not name" for g in self.unnamed]
        out += [f"{g}: a staging folder left by an interrupted ingest" for g in self.staging]
        return out


def _check_file(path: Path, rec: dict | None, rel: str) -> str | None:
    """The problem of one stored file, or None when it is as the manifest records."""
    if not path.is_file():
        return f"{rel}: missing"
    if isinstance(rec, dict):
        problem = recorded_mismatch(path, rec)
        return None if problem is None else f"{rel}: {problem}"
    try:  # a store written before hashes were recorded: at least a whole Parquet file
        pq.read_metadata(path)
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        return f"{rel}: not a readable Parquet file ({exc})"
    return None


def _session_problems(store: Path, manifest: dict, sid: str, entry) -> list[str]:
    """The problems of one session's stored files, one line each (empty: as recorded)."""
    gen = manifest.get("generation")
    files = entry.get("store_files") if isinstance(entry, dict) else None
    if gen is not None and not isinstance(files, dict):
        return ["the manifest lists no stored files"]
    checks = (entry.get("store_checks") or {}) if isinstance(entry, dict) else {}
    problems = []
    for kind in KINDS:
        rel = listed_files(manifest, kind).get(sid)
        if rel is None or (gen is None and not (store / rel).is_file()):
            continue
        problem = _check_file(store / rel, checks.get(kind), rel)
        if problem is None and kind == "points" and isinstance(entry, dict) \
                and isinstance(entry.get("n_points"), int):
            rows = pq.read_metadata(store / rel).num_rows
            if rows != entry["n_points"]:
                problem = f"{rel}: {rows} points, {entry['n_points']} recorded"
        if problem is not None:
            problems.append(problem)
    return problems


def check_store(store_dir: str | Path, manifest: dict | None = None) -> StoreDamage:
    """Verify every file the manifest lists: present, its size and SHA-256 as recorded.

    Reads the store and changes nothing. Files of stores written before the
    manifest recorded hashes are checked for being whole Parquet files.

    Parameters
    ----------
    store_dir : str or Path
        The store.
    manifest : dict, optional
        A manifest already read (default: read it now).

    Returns
    -------
    StoreDamage
    """
    store = Path(store_dir)
    manifest = read_manifest(store) if manifest is None else manifest
    damage = StoreDamage()
    gen = manifest.get("generation")
    if store.is_dir():
        for p in sorted(store.iterdir()):
            if p.name.startswith(STAGING_PREFIX):
                damage.staging.append(p.name)
            elif GENERATION_RE.match(p.name) and p.name != gen:
                damage.unnamed.append(p.name)
    if gen is not None and not (store / gen).is_dir():
        damage.generation = (f"the manifest names generation {gen}, which does not exist"
                             + (f" (found: {', '.join(damage.unnamed)})" if damage.unnamed
                                else ""))
    for sid, entry in manifest["sessions"].items():
        problems = _session_problems(store, manifest, sid, entry)
        if problems:
            damage.sessions[sid] = problems
    return damage
