"""The one writer of a store: lock, scratch space, generation commit, cleanup.

A generation is built whole in a staging folder (new sessions' files moved in,
kept sessions' files hard-linked from the current generation), renamed into
place, and only then does ``manifest.json`` switch to it by one atomic
:func:`os.replace`.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from bench.store.damage import StoreDamage, check_store
from bench.store.lock import StoreLock
from bench.store.manifest import dumps, empty_manifest, kind_files, read_manifest
from bench.store.schema import GENERATION_RE, KINDS, SCHEMA_NAME, SCHEMA_VERSION, STAGING_PREFIX
from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS, file_sha256, fsync_path, write_text_durable
from kernel.provenance import HEADER_KEY, Provenance


def _link_or_copy(src: Path, dest: Path) -> None:
    try:
        os.link(src, dest)
    except OSError:
        shutil.copy2(src, dest)


def _fill_generation(build: Path, store: Path, old: dict, kept: dict[str, dict],
                     staged: dict[str, dict[str, Path]],
                     entries: dict[str, dict]) -> dict[str, dict]:
    """Put every session's files into the generation folder ``build``.

    Kept sessions' files are hard-linked from the current generation, the
    rewritten sessions' staged files moved in. Returns session_id -> manifest
    entry with its ``store_files``, sorted by id.
    """
    for kind in KINDS:
        (build / kind).mkdir(parents=True)
    sessions = {}
    for sid, entry in kept.items():
        files = {}
        for kind in KINDS:
            src = kind_files(store, kind, old).get(sid)
            if src is not None and src.is_file():
                rel = f"{kind}/{sid}.parquet"
                _link_or_copy(src, build / rel)
                files[kind] = rel
        sessions[sid] = {**entry, "store_files": files}
    for sid, entry in entries.items():
        files = {}
        for kind in KINDS:
            if kind in staged.get(sid, {}):
                rel = f"{kind}/{sid}.parquet"
                os.replace(staged[sid][kind], build / rel)
                files[kind] = rel
        sessions[sid] = {**entry, "store_files": files}
    for sid, entry in sessions.items():  # what check_store verifies later
        recorded = (entry.get("store_checks") or {}) if sid in kept else {}
        entry["store_checks"] = {
            kind: recorded.get(kind) or {"bytes": (build / rel).stat().st_size,
                                         "sha256": file_sha256(build / rel)}
            for kind, rel in entry["store_files"].items()}
    return dict(sorted(sessions.items()))


class StoreWriter:
    """The one writer of a store: lock, scratch space, generation commit, cleanup.

    Use as a context manager::

        with StoreWriter(store_dir) as w:
            ...write files into w.stage...
            w.commit(staged, entries)

    Entering takes an exclusive ``flock`` on ``<store>/.lock`` (creating the store
    when missing), waiting for another writer with a message (or raising
    :class:`~bench.store.lock.StoreBusy` when ``wait`` is False), then removes what
    an interrupted writer left: staging folders and generations the manifest does
    not name. Leaving removes the scratch space; a store this writer created is
    removed again when nothing was committed.

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
        self._lock = StoreLock(self.store, wait,
                               notify or (lambda msg: print(msg, file=sys.stderr, flush=True)))
        self.committed = False
        self.stage: Path | None = None
        self.manifest: dict = empty_manifest()
        #: what :func:`check_store` found when the writer entered
        self.damage = StoreDamage()

    @property
    def created(self) -> bool:
        """True when this writer created the store folder."""
        return self._lock.created

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
            self._lock.acquire()
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
            self._lock.release()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if self.stage is not None:
                shutil.rmtree(self.stage, ignore_errors=True)
            if self.created and not self.committed:
                shutil.rmtree(self.store, ignore_errors=True)
        finally:
            self._lock.release()

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

    def _switch(self, build: Path, gen: str, text: str) -> None:
        """Flush the generation, rename it into place and switch the manifest to it."""
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
        kept = {sid: e for sid, e in old["sessions"].items() if sid not in entries}
        self.require_repair(entries)
        build = self.stage / gen
        new = {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, "generation": gen,
               HEADER_KEY: self.provenance.header(),
               "sessions": _fill_generation(build, self.store, old, kept, staged, entries)}
        try:
            text = dumps(new)
        except (TypeError, ValueError) as exc:
            raise InputError(self.store / "manifest.json",
                             f"a session's metadata cannot be stored ({exc})",
                             expected="finite numbers, text, dates") from exc
        self._switch(build, gen, text)
        self.manifest = new
        self.damage = StoreDamage()
        self._clean()
        return new
