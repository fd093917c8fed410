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
removed by the next writer. One writer at a time: :class:`StoreWriter` holds an
exclusive ``flock`` on ``<store>/.lock``.

Readers: :func:`read_manifest`, :func:`kind_files`, :func:`read_points`,
:func:`read_rejected`, :func:`read_samples`. They read only the files the
manifest lists; a store written before generations (schema_version 1, files
directly in ``<store>/points`` etc.) is still read.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from kernel.errors import InputError
from kernel.files import (
    WRITE_ERRNOS,
    dumps_json,
    file_sha256,
    fsync_path,
    read_json,
    write_text_durable,
)
from kernel.provenance import HEADER_KEY, Provenance

SCHEMA_NAME = "drivebench.store"
SCHEMA_VERSION = 2
#: manifests this version reads (1: no generations, files directly in <store>/<kind>)
READABLE_VERSIONS = (1, 2)
KINDS = ("points", "samples", "rejected")
LOCK_FILE = ".lock"
STAGING_PREFIX = ".staging-"
GENERATION_RE = re.compile(r"^gen-(\d{6,})$")
#: times a reader starts over when a writer removed a generation under it
READ_RETRIES = 5

T = TypeVar("T")


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
    _f("n_samples", pa.int64()),
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

_SCHEMAS = {"points": POINTS_SCHEMA, "samples": SAMPLES_SCHEMA, "rejected": REJECTED_SCHEMA}


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


def _listed(manifest: dict, kind: str) -> dict[str, str]:
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
    paths = {sid: store / rel for sid, rel in _listed(manifest, kind).items()}
    if manifest.get("generation") is None:  # v1 stores: a session may lack a kind
        paths = {sid: p for sid, p in paths.items() if p.is_file()}
    return paths


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
                                 expected="re-run bench ingest into a new store") from exc
    raise InputError(store_dir, f"the store changed {READ_RETRIES} times while being read",
                     expected="no ingest running into it")


def _check_bytes(path: Path, data: bytes, entry: dict, kind: str) -> None:
    """Raise InputError when ``data`` differs from the size and hash the manifest records."""
    rec = (entry.get("store_checks") or {}).get(kind) if isinstance(entry, dict) else None
    if not isinstance(rec, dict):
        return  # a store written before the manifest recorded its files' hashes
    if len(data) != rec.get("bytes") or hashlib.sha256(data).hexdigest() != rec.get("sha256"):
        raise InputError(path, f"the file differs from what the store manifest records "
                         f"({len(data)} bytes, {rec.get('bytes')} recorded): damaged store",
                         expected="run bench store check, then re-run bench ingest")


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
    out = {}
    for sid, path in kind_files(store_dir, kind, manifest).items():
        data = path.read_bytes()
        _check_bytes(path, data, manifest["sessions"].get(sid), kind)
        out[sid] = (path, data)
    return out


def parse_parquet(path: Path, data: bytes) -> pd.DataFrame:
    """A store file's bytes as a frame; InputError naming the file when it is no Parquet."""
    try:
        return pd.read_parquet(io.BytesIO(data))
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        raise InputError(path, f"not a readable Parquet file ({exc}): damaged store",
                         expected="run bench store check, then re-run bench ingest") from exc


def _read_kind(store_dir: str | Path, kind: str) -> pd.DataFrame:
    def read(manifest: dict) -> pd.DataFrame:
        frames = [parse_parquet(p, data)
                  for p, data in read_listed_bytes(store_dir, kind, manifest).values()]
        if not frames:
            return _SCHEMAS[kind].empty_table().to_pandas()
        return pd.concat(frames, ignore_index=True)

    return consistent_read(store_dir, read)


def read_points(store_dir: str | Path) -> pd.DataFrame:
    """All operating points of the store, one row each (docs/schemas.md section 2)."""
    return _read_kind(store_dir, "points")


def read_rejected(store_dir: str | Path) -> pd.DataFrame:
    """All rejected steady-state windows with their reasons."""
    return _read_kind(store_dir, "rejected")


def read_samples(store_dir: str | Path, session_id: str) -> pd.DataFrame:
    """The aligned time series of one timeseries session."""
    def read(manifest: dict) -> pd.DataFrame:
        path = kind_files(store_dir, "samples", manifest).get(session_id)
        if path is None:
            raise InputError(Path(store_dir) / "manifest.json",
                             f"no samples for session {session_id!r}")
        data = path.read_bytes()
        _check_bytes(path, data, manifest["sessions"].get(session_id), "samples")
        return parse_parquet(path, data)

    return consistent_read(store_dir, read)


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
        size = path.stat().st_size
        if size != rec.get("bytes"):
            return f"{rel}: {size} bytes, {rec.get('bytes')} recorded"
        if file_sha256(path) != rec.get("sha256"):
            return f"{rel}: content differs from the recorded SHA-256 (bit rot or an edit)"
        return None
    try:  # a store written before hashes were recorded: at least a whole Parquet file
        pq.read_metadata(path)
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        return f"{rel}: not a readable Parquet file ({exc})"
    return None


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
        files = entry.get("store_files") if isinstance(entry, dict) else None
        if gen is not None and not isinstance(files, dict):
            damage.sessions[sid] = ["the manifest lists no stored files"]
            continue
        checks = (entry.get("store_checks") or {}) if isinstance(entry, dict) else {}
        problems = []
        for kind in KINDS:
            rel = _listed(manifest, kind).get(sid)
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
        if problems:
            damage.sessions[sid] = problems
    return damage


def dumps(obj) -> str:
    """JSON text of a manifest: sorted keys, stable bytes, never NaN or Infinity.

    Raises
    ------
    ValueError
        A non-finite float anywhere in ``obj`` (JSON has none).
    """
    return dumps_json(obj, indent=1, sort_keys=True, non_finite="error")


def _link_or_copy(src: Path, dest: Path) -> None:
    try:
        os.link(src, dest)
    except OSError:
        shutil.copy2(src, dest)


def _lock(fd: int, block: bool) -> None:
    """Exclusive lock on an open file; BlockingIOError when taken and ``block`` is False.

    ``flock`` on POSIX (released when the process ends, however it ends);
    ``msvcrt.locking`` of the first byte on Windows.
    """
    try:
        import fcntl
    except ImportError:  # Windows
        import msvcrt
        import time as _time

        while True:
            os.lseek(fd, 0, os.SEEK_SET)
            try:
                msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
                return
            except OSError as exc:
                if not block:
                    raise BlockingIOError(*exc.args) from exc
                _time.sleep(0.2)
    fcntl.flock(fd, fcntl.LOCK_EX | (0 if block else fcntl.LOCK_NB))


def _read_at_start(fd: int) -> str:
    """The text at the start of the lock file (the holder's pid), without the lock."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, 64).decode("ascii", "replace")
    except OSError:  # Windows: the locked byte cannot be read
        return ""


def _write_pid(fd: int) -> None:
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    os.write(fd, f"{os.getpid()}\n".encode())


class StoreBusy(InputError):
    """Another ingest holds the store's lock and the caller chose not to wait."""


class StoreWriter:
    """The one writer of a store: lock, scratch space, generation commit, cleanup.

    Use as a context manager::

        with StoreWriter(store_dir) as w:
            ...write files into w.stage...
            w.commit(staged, entries)

    Entering takes an exclusive ``flock`` on ``<store>/.lock`` (creating the store
    when missing), waiting for another writer with a message (or raising
    :class:`StoreBusy` when ``wait`` is False), then removes what an interrupted
    writer left: staging folders and generations the manifest does not name.
    Leaving removes the scratch space; a store this writer created is removed
    again when nothing was committed.

    Parameters
    ----------
    store_dir : str or Path
        The store.
    wait : bool
        Wait for another writer (default) or stop at once.
    notify : callable
        Called with one line when waiting (default: print to stderr).
    """

    def __init__(self, store_dir: str | Path, wait: bool = True,
                 notify: Callable[[str], None] | None = None,
                 provenance: Provenance | None = None) -> None:
        self.store = Path(store_dir)
        #: the provenance header of the manifest this writer commits (:mod:`kernel.provenance`)
        self.provenance = provenance or Provenance.start(sys.argv)
        self.wait = wait
        self.notify = notify or (lambda msg: print(msg, file=sys.stderr, flush=True))
        self.created = False
        self.committed = False
        self._fd: int | None = None
        self.stage: Path | None = None
        self.manifest: dict = empty_manifest()
        #: what :func:`check_store` found when the writer entered
        self.damage = StoreDamage()

    # -- lock -------------------------------------------------------------------------
    def _acquire(self) -> None:
        lock_path = self.store / LOCK_FILE
        while True:
            if self.store.exists() and not self.store.is_dir():
                raise InputError(self.store, "the store is not a directory",
                                 expected="a store directory (created when missing)")
            try:
                if not self.store.exists():
                    try:
                        self.store.mkdir(parents=True)
                        self.created = True
                    except FileExistsError:
                        pass
                fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o666)
            except FileNotFoundError:  # the store vanished between mkdir and open: retry
                continue
            except OSError as exc:
                reason = WRITE_ERRNOS.get(exc.errno, exc.strerror or str(exc))
                raise InputError(self.store, f"cannot write to the store ({reason})",
                                 expected="a writable store directory") from exc
            try:
                _lock(fd, block=False)
            except BlockingIOError as busy:
                holder = _read_at_start(fd).strip() or "?"
                if not self.wait:
                    os.close(fd)
                    raise StoreBusy(self.store,
                                    f"another ingest (pid {holder}) is writing this store",
                                    expected="one ingest per store at a time") from busy
                self.notify(f"bench ingest: waiting for another ingest (pid {holder}) "
                            f"writing {self.store} ...")
                _lock(fd, block=True)
            # the holder may have removed the store (a failed first ingest): lock again
            try:
                same = os.fstat(fd).st_ino == os.stat(lock_path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                self._fd = fd
                _write_pid(fd)
                return
            os.close(fd)

    def _release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing drops the flock
            self._fd = None

    # -- cleanup ----------------------------------------------------------------------
    def _clean(self) -> None:
        """Remove staging folders; generations the manifest does not name only when the
        one it names is complete (:attr:`damage`): a generation is never removed unless
        a complete one supersedes it."""
        keep = self.manifest.get("generation")
        complete = not self.damage.damaged
        for p in self.store.iterdir():
            if p.name.startswith(STAGING_PREFIX) or (
                    complete and GENERATION_RE.match(p.name) and p.name != keep):
                shutil.rmtree(p, ignore_errors=True)
            elif p.name.startswith(".manifest.json.") and p.name.endswith(".tmp"):
                p.unlink(missing_ok=True)
        if keep is not None and complete:  # a v1 store migrated to generations: its old
            for kind in KINDS:              # folders go
                if (self.store / kind).is_dir():
                    shutil.rmtree(self.store / kind, ignore_errors=True)

    def __enter__(self) -> StoreWriter:
        try:
            self._acquire()
        except BaseException:
            if self.created:
                shutil.rmtree(self.store, ignore_errors=True)
            raise
        try:
            self.manifest = read_manifest(self.store)
            self.damage = check_store(self.store, self.manifest)
            self._clean()
            self.stage = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=self.store))
        except BaseException:
            self._release()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if self.stage is not None:
                shutil.rmtree(self.stage, ignore_errors=True)
            if self.created and not self.committed:
                shutil.rmtree(self.store, ignore_errors=True)
        finally:
            self._release()

    # -- commit -----------------------------------------------------------------------
    def _next_generation(self) -> str:
        numbers = [int(m.group(1)) for p in self.store.iterdir()
                   if (m := GENERATION_RE.match(p.name))]
        cur = self.manifest.get("generation")
        if cur is not None:
            numbers.append(int(GENERATION_RE.match(cur).group(1)))
        return f"gen-{max(numbers, default=0) + 1:06d}"

    def require_repair(self, rewritten) -> None:
        """Raise InputError unless every damaged session is among ``rewritten`` (ids).

        A new generation hard-links the sessions it keeps from the current one, so a
        damaged session can only be kept by ingesting its folder again.
        """
        old = self.manifest["sessions"]
        kept = set(old) - set(rewritten)
        damaged = sorted(kept if self.damage.generation is not None
                         else kept & set(self.damage.sessions))
        if damaged:
            raise InputError(self.store / "manifest.json",
                             "stored sessions are damaged and not ingested now: "
                             + "; ".join(f"{sid!r} (from {old[sid].get('source')})"
                                         for sid in damaged),
                             expected="their session folders ingested too (bench store "
                                      "check lists the damage)")

    def commit(self, staged: dict[str, dict[str, Path]], entries: dict[str, dict]) -> dict:
        """Write a new generation and switch the manifest to it in one atomic step.

        Parameters
        ----------
        staged : dict
            session_id -> {kind: staged Parquet file} of the sessions (re)written;
            kinds a session lacks are absent from the new generation.
        entries : dict
            session_id -> manifest entry of those sessions; the other sessions of
            the current manifest are kept (their files hard-linked).

        Returns
        -------
        dict
            The new manifest.

        Raises
        ------
        InputError
            An entry that cannot be written as JSON (e.g. NaN), before anything changed.
        """
        assert self.stage is not None, "commit outside the writer's context"
        old = self.manifest
        gen = self._next_generation()
        sessions = {sid: e for sid, e in old["sessions"].items() if sid not in entries}
        self.require_repair(entries)
        new = {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, "generation": gen,
               HEADER_KEY: self.provenance.header(), "sessions": {}}
        build = self.stage / gen
        for kind in KINDS:
            (build / kind).mkdir(parents=True)
        # kept sessions: hard links to the current generation's files
        for sid, entry in sessions.items():
            files = {}
            for kind in KINDS:
                src = kind_files(self.store, kind, old).get(sid)
                if src is not None and src.is_file():
                    rel = f"{kind}/{sid}.parquet"
                    _link_or_copy(src, build / rel)
                    files[kind] = rel
            new["sessions"][sid] = {**entry, "store_files": files}
        for sid, entry in entries.items():
            files = {}
            for kind in KINDS:
                if kind in staged.get(sid, {}):
                    rel = f"{kind}/{sid}.parquet"
                    os.replace(staged[sid][kind], build / rel)
                    files[kind] = rel
            new["sessions"][sid] = {**entry, "store_files": files}
        for sid, entry in new["sessions"].items():  # what check_store verifies later
            recorded = (entry.get("store_checks") or {}) if sid in sessions else {}
            entry["store_checks"] = {
                kind: recorded.get(kind) or {"bytes": (build / rel).stat().st_size,
                                             "sha256": file_sha256(build / rel)}
                for kind, rel in entry["store_files"].items()}
        new["sessions"] = dict(sorted(new["sessions"].items()))
        try:
            text = dumps(new)
        except (TypeError, ValueError) as exc:
            raise InputError(self.store / "manifest.json",
                             f"a session's metadata cannot be stored ({exc})",
                             expected="finite numbers, text, dates") from exc
        try:
            for kind in KINDS:
                for p in (build / kind).iterdir():
                    fsync_path(p)
                fsync_path(build / kind)
            fsync_path(build)
            os.replace(build, self.store / gen)
            fsync_path(self.store)
            write_text_durable(self.store / "manifest.json", text)  # the switch
            self.committed = True
            fsync_path(self.store)
        except OSError as exc:
            if exc.errno in WRITE_ERRNOS:
                raise
            raise InputError(exc.filename or self.store,
                             f"cannot flush the store to disk ({exc.strerror or exc}): "
                             + ("the manifest names the new generation, but it may not be "
                                "on disk" if self.committed else "nothing was committed"),
                             expected="a working disk; run bench ingest again") from exc
        self.manifest = new
        self.damage = StoreDamage()
        self._clean()
        return new
