"""Ingest orchestration: discover sessions, skip unchanged ones, process, commit atomically.

Every session is processed into a staging directory inside the store before
anything in the store changes; only when all sessions succeeded does the store
switch to a new generation holding them (:class:`bench.store.writer.StoreWriter`, one
writer at a time, all or nothing). A session whose source
files hash as recorded in the manifest is not touched, so re-ingesting the same
files changes no byte of the store.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import pyarrow.parquet as pq
from tqdm import tqdm

from bench.ingest.checks import efficiency_flags
from bench.ingest.csv_stream import CHUNK_BYTES
from bench.ingest.cycle_run import process_cycle_run
from bench.ingest.mapping import EMPTY_MAPPING, load_mapping
from bench.ingest.session import Session, complete_ranges, discover, load_session
from bench.ingest.steady import DEFAULT_STEADY, SteadyConfig
from bench.ingest.store_tables import SessionOutput
from bench.ingest.table import process_table
from bench.ingest.timeseries import process_timeseries
from bench.store.manifest import read_manifest
from bench.store.writer import StoreWriter
from kernel.drive_file import find_drive_file, session_drive
from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS, file_sha256
from kernel.output_place import check_place
from kernel.provenance import Provenance

#: bump when ingest would compute different points from the same files; sessions
#: stored by another version are re-ingested
INGEST_VERSION = 5  # 2: torque zero offset from the tare; 3: oscillations cut into pieces;
#                    4: the drive rating (drive.toml, session.toml) in the manifest;
#                    5: bins follow the sample interval (grid centred on the samples), time
#                    gaps end windows


@dataclass
class IngestResult:
    """What an ingest did.

    Parameters
    ----------
    store_dir : Path
        The store.
    ingested : list of str
        Sessions (re)written.
    unchanged : list of str
        Sessions skipped because their files hash as in the manifest.
    manifest : dict
        The store's manifest afterwards.
    replaced : dict
        session_id -> the folder it had been ingested from, for stored sessions
        replaced by a session of the same id from another folder.
    repaired : dict
        session_id -> the damage found in its stored files (missing, truncated,
        altered), for sessions re-ingested because of it.
    """

    store_dir: Path
    ingested: list[str] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)
    manifest: dict = field(default_factory=dict)
    replaced: dict[str, str] = field(default_factory=dict)
    repaired: dict[str, list[str]] = field(default_factory=dict)


def to_stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def session_files(
    session: Session, user_mapping: Path | None
) -> tuple[dict[str, Path], Path | None]:
    """Source files of a session (for hashing) and the mapping file that applies to it.

    The session's own mapping (``[points] mapping`` or a ``mapping.toml`` beside
    ``session.toml``) wins; else the user's ``--mapping`` file applies.
    """
    files = {"session.toml": session.path}
    if session.kind == "operating_points":
        tables: tuple[str, ...] = ("points",)
    else:
        tables = ("log",) if session.single_stream else ("daq", "analyzer")
    for t in tables:
        p = session.file(t)
        files[p.name] = p
    if session.kind == "cycle_run":
        p = session.profile()
        files[p.name] = p
    mapping = None
    named = session.raw.get("points", {}).get("mapping") if session.kind == "operating_points" \
        else None
    if named:
        if not isinstance(named, str):
            raise InputError(session.path, f"bad value {named!r}", column="points.mapping",
                             expected="a file name in the session folder")
        mapping = session.inside(named, "points.mapping")
    else:  # a mapping beside session.toml, never one a link puts elsewhere
        beside = [n for n in ("mapping.toml", "mapping.json")
                  if (session.folder / n).exists() or (session.folder / n).is_symlink()]
        if beside:
            mapping = session.inside(beside[0], beside[0])
    if mapping is not None:
        files[mapping.name] = mapping
    elif user_mapping is not None:
        mapping = user_mapping
    return files, mapping


def ingest(
    paths: list[str | Path],
    store_dir: str | Path,
    mapping_path: str | Path | None = None,
    config: SteadyConfig = DEFAULT_STEADY,
    progress: bool = True,
    chunk_bytes: int = CHUNK_BYTES,
    workers: int = 2,
    strict: bool = False,
    wait: bool = True,
    replace: bool = True,
    notify: Callable[[str], None] = to_stderr,
    command_line: Sequence[str] = ("drivebench.ingest",),
) -> IngestResult:
    """Ingest every session under ``paths`` into the store at ``store_dir``.

    Parameters
    ----------
    paths : list of str or Path
        Campaign or session folders.
    store_dir : str or Path
        The store (created when missing).
    mapping_path : str or Path, optional
        Mapping file for sessions that have none of their own.
    config : SteadyConfig
        Steady-state detection settings.
    progress : bool
        Show a tqdm progress bar (bytes of source data).
    chunk_bytes : int
        CSV bytes parsed per chunk [B]; bounds memory.
    workers : int
        Sessions processed at the same time (threads); memory grows with it.
    strict : bool
        A session that gives no operating point is an error (InputError naming
        its session.toml and why), and the store is left as it was; without it
        the manifest and the summary say why.
    wait : bool
        Wait for another ingest writing the same store (default), else stop (InputError).
    replace : bool
        Replace stored sessions of the same id from another folder (default, said through
        ``notify``), else stop naming them before anything changes (InputError).
    notify : callable
        Receives the lines that say what happens besides the summary.
    command_line : sequence of str
        Recorded in the store manifest's provenance header (:mod:`kernel.provenance`).

    Returns
    -------
    IngestResult

    Raises
    ------
    InputError
        Any bad input; the store is then left exactly as it was.
    """
    store_dir = Path(store_dir)
    user_mapping = _checked_options(mapping_path, store_dir)
    sessions, seen, drives = _load_sessions(paths, notify)
    result = IngestResult(store_dir=store_dir)
    with StoreWriter(store_dir, wait=wait, notify=notify,
                     provenance=Provenance.start(command_line)) as writer:
        _say_store_problems(writer, notify)
        # hashing runs in a background thread (hashlib releases the GIL); a session
        # already in the manifest waits for its hashes to decide whether it changed
        hasher = ThreadPoolExecutor(max_workers=1)
        try:
            todo = [item for s in sessions
                    if (item := _changed(s, user_mapping, drives[s.session_id][1], writer,
                                         hasher, result, notify)) is not None]
            writer.require_repair(seen)
            _say_replaced(result, replace, seen, store_dir, notify)
            if strict:
                _strict_unchanged(sessions, result.unchanged, writer.manifest)
            if todo:
                _process_into_store(todo, writer, config, progress, chunk_bytes, workers,
                                    result, {sid: d for sid, (d, _) in drives.items()}, strict)
        finally:
            hasher.shutdown(cancel_futures=True)
        result.manifest = writer.manifest
    return result


def _say_store_problems(writer: StoreWriter, notify: Callable[[str], None]) -> None:
    """Say what the store check found besides damaged sessions (those are re-ingested and
    said so): a missing generation, folders an interrupted ingest left."""
    for line in writer.damage.lines():
        if not line.startswith("session "):
            notify(f"bench ingest: store {writer.store}: {line}")


def _checked_options(mapping_path: str | Path | None, store_dir: Path) -> Path | None:
    """The ``--mapping`` file, read once to fail early when it is bad, after which the
    store path is checked (InputError when it is no store, or lies inside another
    stage's output or store)."""
    user_mapping = Path(mapping_path) if mapping_path is not None else None
    if user_mapping is not None:
        load_mapping(user_mapping)  # fail early on a bad --mapping file
    check_place(store_dir, "--store")  # not inside another stage's output or store
    read_manifest(store_dir)  # fail early on a path that is no store
    return user_mapping


def _load_sessions(paths: list[str | Path], notify: Callable[[str], None]) -> tuple[
        list[Session], dict[str, Path], dict[str, tuple[dict | None, Path | None]]]:
    """The sessions under ``paths`` (their sensor ranges completed from the drive rating),
    session_id -> its folder, and session_id -> (drive rating, drive.toml).

    Raises
    ------
    InputError
        A bad session.toml or drive.toml, a session id found twice.
    """
    sessions: list[Session] = []
    seen: dict[str, Path] = {}
    drives: dict[str, tuple[dict | None, Path | None]] = {}  # rating, drive.toml
    for folder in discover(paths, notify):
        s = load_session(folder)
        drive_file = find_drive_file(folder, [Path(p) for p in paths])
        label = "" if drive_file is None else os.path.relpath(drive_file, folder.parent)
        rating = session_drive(s.raw, s.path, drive_file, label)
        s, note = complete_ranges(s, rating)
        if note is not None:
            notify(f"bench ingest: {note}")
        if s.session_id in seen:
            raise InputError(folder, f"session {s.session_id!r} found twice",
                             expected=f"unique session ids (also in {seen[s.session_id]})")
        seen[s.session_id] = folder
        sessions.append(s)
        drives[s.session_id] = (rating, drive_file)
    return sessions, seen, drives


def _changed(s: Session, user_mapping: Path | None, drive_file: Path | None,
             writer: StoreWriter, hasher: ThreadPoolExecutor, result: IngestResult,
             notify: Callable[[str], None]) -> tuple | None:
    """The work item ``(session, hashes, mapping file, files)`` of a session to (re)ingest;
    None (and the session listed as unchanged) when its files hash as recorded."""
    files, mapping_file = session_files(s, user_mapping)
    named = {f"{s.session_id}/{name}": p for name, p in files.items()}
    if mapping_file is not None and mapping_file not in files.values():
        named[f"--mapping/{mapping_file.name}"] = mapping_file
    if drive_file is not None:  # a changed drive.toml re-ingests the session
        named[f"campaign/{os.path.relpath(drive_file, s.folder.parent)}"] = drive_file
    hashes = {k: hasher.submit(file_sha256, p) for k, p in named.items()}
    old = writer.manifest["sessions"].get(s.session_id)
    damage = writer.damage
    broken = damage.sessions.get(s.session_id) or (
        [damage.generation] if old is not None and damage.generation else [])
    if broken:
        result.repaired[s.session_id] = broken
        notify(f"bench ingest: stored files of session {s.session_id!r} are "
               f"damaged ({'; '.join(broken)}); re-ingesting it")
    elif (old is not None and old.get("ingest_version") == INGEST_VERSION
            and old.get("files") == {k: f.result() for k, f in hashes.items()}):
        result.unchanged.append(s.session_id)
        return None
    if old is not None and old.get("source") not in (None, str(s.folder)):
        result.replaced[s.session_id] = old["source"]
    return s, hashes, mapping_file, files


def _say_replaced(result: IngestResult, replace: bool, seen: dict[str, Path],
                  store_dir: Path, notify: Callable[[str], None]) -> None:
    """Name the stored sessions a session of the same id from another folder replaces;
    refuse (InputError) when ``replace`` is False."""
    if result.replaced and not replace:
        lines = "; ".join(f"{sid!r} (stored from {src})"
                          for sid, src in sorted(result.replaced.items()))
        raise InputError(store_dir, f"would replace stored sessions of another "
                         f"source: {lines}",
                         expected="new session ids, or no --no-replace")
    for sid, src in sorted(result.replaced.items()):
        notify(f"bench ingest: replacing stored session {sid!r} (from {src}) "
               f"with {seen[sid]}")


def _process_into_store(todo, writer: StoreWriter, *args) -> None:
    """:func:`_process`, an error writing the store named as such (nothing committed)."""
    try:
        _process(todo, writer, *args)
    except OSError as exc:  # writing the store: name it
        if exc.errno not in WRITE_ERRNOS:
            raise
        reason = WRITE_ERRNOS[exc.errno]
        raise InputError(writer.store, f"cannot write to the store ({reason}); "
                         "nothing was committed",
                         expected="free space for the store") from exc


def _strict_check(s: Session, entry: dict) -> None:
    """``--strict``: raise when a session's entry has no operating point (a cycle run:
    no kept cycle)."""
    if s.kind == "cycle_run":
        if (entry.get("cycles") or {}).get("n_kept", 0) == 0:
            raise InputError(s.path, entry.get("no_points_note", "no cycle kept"),
                             expected="at least one kept cycle (--strict)")
        return
    if entry.get("n_points", 0) == 0:
        raise InputError(s.path, entry.get("no_points_note", "0 points"),
                         expected="at least one steady operating point (--strict)")


def _strict_unchanged(sessions: list[Session], unchanged: list[str], manifest: dict) -> None:
    """``--strict``: :func:`_strict_check` of the sessions not ingested again."""
    for s in sessions:
        if s.session_id in unchanged:
            _strict_check(s, manifest["sessions"][s.session_id])


def _process(todo, writer: StoreWriter, config: SteadyConfig, progress: bool,
             chunk_bytes: int, workers: int, result: IngestResult,
             drives: dict[str, dict | None], strict: bool = False) -> None:
    """Process the changed sessions into the writer's staging dir, then commit them at once.

    Sessions run in ``workers`` threads: parsing, numpy and Parquet writing release
    the GIL, so two sessions use two cores. The first failing session (in session
    order) raises; nothing has been committed then.
    """
    total = sum(p.stat().st_size for _, _, _, files in todo for p in files.values())
    lock = threading.Lock()
    stage = writer.stage
    with tqdm(total=total, unit="B", unit_scale=True, desc="ingest",
              disable=not progress) as bar:

        def one(item) -> tuple[dict[str, Path], SessionOutput]:
            s, _, mapping_file, files = item
            mapping = load_mapping(mapping_file) if mapping_file is not None else EMPTY_MAPPING
            size = sum(p.stat().st_size for p in files.values())
            done = [0]

            def tick(n: int) -> None:
                with lock:
                    n = min(n, size - done[0])
                    done[0] += n
                    bar.update(n)

            if s.kind == "timeseries":
                out = process_timeseries(s, mapping, stage, config, chunk_bytes, tick)
            elif s.kind == "cycle_run":
                out = process_cycle_run(s, mapping, stage, config, chunk_bytes, tick)
            else:
                out = process_table(s, mapping)
            tick(size)
            return _stage(stage, s.session_id, out), out

        if workers <= 1 or len(todo) == 1:
            outputs = [one(item) for item in todo]
        else:
            pool = ThreadPoolExecutor(max_workers=workers)
            try:
                futures = [pool.submit(one, item) for item in todo]
                outputs = [f.result() for f in futures]
            finally:
                pool.shutdown(wait=True, cancel_futures=True)
    staged: dict[str, dict[str, Path]] = {}
    entries: dict[str, dict] = {}
    for (s, hashes, _, _), (files, out) in zip(todo, outputs, strict=True):
        staged[s.session_id] = files
        entries[s.session_id] = _entry(s, {k: f.result() for k, f in hashes.items()}, out,
                                       drives.get(s.session_id))
        if strict:
            _strict_check(s, entries[s.session_id])
        result.ingested.append(s.session_id)
    writer.commit(staged, entries)


def _stage(stage: Path, sid: str, out: SessionOutput) -> dict[str, Path]:
    files = {}
    for kind, table in (("points", out.points), ("rejected", out.rejected),
                        ("cycles", out.cycles)):
        if table is None:
            continue
        p = stage / f"{sid}.{kind}.parquet"
        pq.write_table(table, p, compression="snappy")
        files[kind] = p
    if out.samples_path is not None:
        files["samples"] = out.samples_path
    return files


def _entry(s: Session, hashes: dict[str, str], out: SessionOutput,
           drive: dict | None) -> dict:
    quadrants = out.points.column("quadrant").to_pylist()
    reasons = out.rejected.column("reason").to_pylist()
    entry = {
        "files": hashes,
        "ingest_version": INGEST_VERSION,
        "kind": s.kind,
        "mode": s.mode,
        "n_points": out.points.num_rows,
        "points_per_quadrant": {q: quadrants.count(q) for q in ("motor", "generator")},
        "rejected": {r: reasons.count(r) for r in sorted(set(reasons))},
        "metadata": s.raw,
        "source": str(s.folder),
        "drive": drive,
        "ingested_at": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    entry.update(out.info)
    flags = efficiency_flags({c: out.points.column(c).to_numpy() for c in out.points.column_names})
    if flags:
        entry["efficiency_flags"] = flags
    if out.points.num_rows == 0 and "no_points_note" not in entry:
        entry["no_points_note"] = "0 points: every row of the table is invalid"
    return entry
