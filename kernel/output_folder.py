"""A stage's output folder, written whole and switched in one step; readers check it.

A stage (``bench fit``, ``optimize``, ``aep``, ``size``) writes every file of its
output folder into a staging sibling ``.<name>.staging-<pid>-*`` (same parent,
same file system). When the stage succeeded, :func:`output_folder` writes
``run.json`` there (the run's provenance header, :mod:`kernel.provenance`, and the
size and SHA-256 of every file), flushes
all of it to disk and puts it in place in one step: an atomic exchange of the
two folders (``renameat2(RENAME_EXCHANGE)`` on Linux), or a plain rename when
the target does not exist yet. A reader thus sees the old folder or the new
one, never a mix; a stage that fails or is killed leaves the old folder as it
was (its staging folder is removed then, or by the next writer once its
process is gone). Where the exchange is not available the old folder is
renamed aside first: a kill between the two renames leaves the target missing
and the old folder beside it, which the next writer puts back.

Readers call :func:`check_output_folder` (or :func:`check_output_file` for one
file of a folder): every file ``run.json`` lists must be there with its size
and hash, and no other file; a folder written before run ids (no ``run.json``)
is read as before.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from kernel.errors import InputError
from kernel.files import (
    file_sha256,
    fsync_path,
    raise_mismatches,
    read_json,
    recorded_mismatch,
    write_text_durable,
)
from kernel.locking import output_lock
from kernel.output_place import RUN_FILE, RUN_SCHEMA, check_place
from kernel.provenance import HEADER_KEY, Provenance

#: output folder -> run id it held when :func:`check_replaceable` passed (this process)
_SEEN: dict[Path, str | None] = {}
SCHEMA_NAME = RUN_SCHEMA
SCHEMA_VERSION = 1
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _leftovers(target: Path, kind: str) -> list[Path]:
    """Staging (``kind="staging"``) or set-aside (``"old"``) folders of dead writers."""
    out = []
    prefix = f".{target.name}.{kind}-"
    for p in target.parent.iterdir():
        if p.name.startswith(prefix):
            pid = p.name[len(prefix):].split("-", 1)[0]
            if not (pid.isdigit() and _alive(int(pid)) and int(pid) != os.getpid()):
                out.append(p)
    return out


def _is_previous_output(target: Path, stage: str, markers: tuple[str, ...],
                        keep: tuple[str, ...]) -> bool:
    if all(p.name in keep for p in target.iterdir()):
        return True
    run_file = target / RUN_FILE
    if run_file.is_file():
        try:
            return json.loads(run_file.read_text(encoding="utf-8")).get("stage") == stage
        except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError):
            return False
    return any((target / m).is_file() for m in markers)


def check_replaceable(target: str | Path, stage: str, markers: tuple[str, ...] = (),
                      option: str = "--out", keep: tuple[str, ...] = ()) -> Path:
    """Raise InputError unless ``target`` is missing, empty or an earlier ``stage`` output.

    The whole folder is replaced by the new output, so a folder holding anything
    else (a project folder given as ``--out`` by mistake) is refused, and so is a
    folder inside another stage's output or a store (:func:`kernel.output_place.check_place`).

    Parameters
    ----------
    target : str or Path
        The output folder.
    stage : str
        The stage name recorded in ``run.json`` (``"fit"``, ``"optimize"``...).
    markers : tuple of str
        Files by which an output of the stage written before run ids is known.
    option : str
        The command-line option that named the folder.
    keep : tuple of str
        Subfolders the stage keeps from run to run (see :func:`output_folder`).
    """
    target = check_place(target, option)
    if target.exists() and not target.is_dir():
        raise InputError(target, "exists and is not a folder", column=option,
                         expected="an output folder (created when missing)")
    if target.is_dir() and not _is_previous_output(target, stage, markers, keep):
        raise InputError(target, f"holds files that are not an earlier bench {stage} output, "
                         "and the whole folder is replaced by the new one", column=option,
                         expected=f"a new or empty folder, or one bench {stage} wrote")
    _SEEN[target.absolute()] = _run_id(target)
    return target


def _run_id(target: Path) -> str | None:
    """The run id in ``target/run.json`` (None: no folder, no record or an unreadable one)."""
    try:
        return json.loads((target / RUN_FILE).read_text(encoding="utf-8")).get("run_id")
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError):
        return None


def _check_unchanged(target: Path, stage: str, option: str) -> None:
    """Stop when another run of the stage wrote ``target`` since :func:`check_replaceable`."""
    if target not in _SEEN:
        return
    seen, now = _SEEN.pop(target), _run_id(target)
    if now != seen:
        raise InputError(target, f"another bench {stage} (run {now}) wrote it while this one "
                         "ran; this run's output is not written", column=option,
                         expected=f"one bench {stage} per output folder at a time (run again)")


def check_replaceable_file(target: str | Path, stage: str, is_earlier: Callable[[bytes], bool],
                           option: str = "--out") -> Path:
    """Raise InputError unless the output file ``target`` is new or an earlier ``stage`` output.

    The rule of :func:`check_replaceable` for a stage that writes one file (``bench
    report``): nothing that stage did not write is ever overwritten, nothing is written
    inside another stage's output or a store.

    Parameters
    ----------
    target : str or Path
        The output file.
    stage : str
        The stage, for the message.
    is_earlier : callable
        Given the file's first 64 KiB, whether the stage wrote it.
    option : str
        The command-line option that named the file.
    """
    target = check_place(target, option)
    if target.is_dir():
        raise InputError(target, "is a folder", column=option, expected="an output file name")
    if target.exists():
        try:
            with open(target, "rb") as fh:
                head = fh.read(1 << 16)
        except OSError as exc:
            raise InputError(target, f"cannot be read ({exc.strerror or exc})", column=option,
                             expected=f"a new file, or one bench {stage} wrote") from exc
        if not is_earlier(head):
            raise InputError(target, f"is not an earlier bench {stage} output and would be "
                             "overwritten", column=option,
                             expected=f"a new file, or one bench {stage} wrote")
    return target


@contextlib.contextmanager
def output_file(target: str | Path, stage: str, is_earlier: Callable[[bytes], bool],
                option: str = "--out") -> Iterator[Path]:
    """Hold the writer's lock of the output file ``target`` and yield it, checked under
    the lock (:func:`check_replaceable_file`); the block writes it (atomically).

    One writer per output file: a second one waits, then finds the first one's output,
    an earlier output of the stage. A refused or failed write leaves nothing behind
    (:func:`kernel.locking.output_lock`).
    """
    with output_lock(target, stage, option=option):
        yield check_replaceable_file(target, stage, is_earlier, option)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two folders atomically; False where the system cannot."""
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    rc = fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _files(folder: Path, keep=()) -> list[Path]:
    """The files under ``folder``, those in its subfolders ``keep`` left out."""
    return sorted(p for p in folder.rglob("*") if p.is_file()
                  and p.relative_to(folder).parts[0] not in keep)


def _record(folder: Path, stage: str, provenance: Provenance, keep: tuple[str, ...]) -> dict:
    return {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, "stage": stage,
            "run_id": provenance.run_id, HEADER_KEY: provenance.header(),
            "kept": list(keep),
            "files": {p.relative_to(folder).as_posix(): {"bytes": p.stat().st_size,
                                                         "sha256": file_sha256(p)}
                      for p in _files(folder, keep) if p.name != RUN_FILE}}


def _switch(stage_dir: Path, target: Path) -> None:
    """Put ``stage_dir`` at ``target`` in one step; the old target ends up removed."""
    if not target.exists():
        os.rename(stage_dir, target)
    elif _exchange(stage_dir, target):
        shutil.rmtree(stage_dir, ignore_errors=True)  # now the old output
    else:
        aside = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-{os.getpid()}-",
                                      dir=target.parent))
        os.rmdir(aside)
        os.rename(target, aside)
        os.rename(stage_dir, target)
        shutil.rmtree(aside, ignore_errors=True)
    fsync_path(target.parent)


@contextlib.contextmanager
def output_folder(target: str | Path, stage: str, markers: tuple[str, ...] = (),
                  option: str = "--out", keep: tuple[str, ...] = (),
                  provenance: Provenance | None = None) -> Iterator[Path]:
    """Yield a staging folder; when the block succeeds it replaces ``target`` whole.

    Parameters
    ----------
    target : str or Path
        The output folder (created when missing).
    stage : str
        The stage name, recorded in ``run.json``.
    markers : tuple of str
        Files by which an earlier output of the stage without ``run.json`` is known.
    option : str
        The command-line option that named the folder (for messages).
    keep : tuple of str
        Subfolders of ``target`` the stage keeps from run to run and writes in
        place (a resumable store of solves): moved into the new folder at the
        switch, left out of ``run.json`` and of the readers' check.
    provenance : Provenance, optional
        The run's provenance (:mod:`kernel.provenance`), whose header and run id
        ``run.json`` records; default a new one of this process's command line.

    Raises
    ------
    InputError
        ``target`` holds something other than an earlier output of ``stage``, or
        the output cannot be flushed to disk (nothing switched then).
    """
    target = check_place(Path(target).absolute(), option)
    with output_lock(target, stage, option=option):
        for p in _leftovers(target, "old"):  # a fallback switch killed between its renames
            if not target.exists():
                os.rename(p, target)
            else:
                shutil.rmtree(p, ignore_errors=True)
        _check_unchanged(target, stage, option)
        check_replaceable(target, stage, markers, option, keep)
        _SEEN.pop(target, None)
        with _staged(target, stage, keep, provenance) as staging:
            yield staging


@contextlib.contextmanager
def _staged(target: Path, stage: str, keep: tuple[str, ...],
            provenance: Provenance | None) -> Iterator[Path]:
    """Yield a staging folder beside ``target``; switch it in when the block succeeds."""
    for p in _leftovers(target, "staging"):
        shutil.rmtree(p, ignore_errors=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.staging-{os.getpid()}-",
                                    dir=target.parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(staging, 0o777 & ~umask)  # a folder's usual permissions, not mkdtemp's 0700
    try:
        yield staging
        for name in keep:
            if (target / name).is_dir() and not (staging / name).exists():
                os.rename(target / name, staging / name)
        record = _record(staging, stage, provenance or Provenance.start(sys.argv), keep)
        try:
            write_text_durable(staging / RUN_FILE, json.dumps(record, indent=1) + "\n")
            for p in _files(staging, keep):
                fsync_path(p)
            for p in sorted({q.parent for q in _files(staging, keep)}, reverse=True):
                fsync_path(p)
        except OSError as exc:
            raise InputError(exc.filename or staging, f"cannot flush the output to disk "
                             f"({exc.strerror or exc}); the old {target.name} is kept",
                             expected="a working disk") from exc
        _switch(staging, target)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)


def _run_of(folder: Path) -> dict | None:
    path = folder / RUN_FILE
    if not path.is_file():
        return None
    run = read_json(path, what="run record")
    if not (isinstance(run, dict) and run.get("schema") == SCHEMA_NAME
            and isinstance(run.get("files"), dict) and isinstance(run.get("run_id"), str)):
        raise InputError(path, "not a drivebench run record", expected="run the stage again")
    return run


def _recorded_run(folder: Path) -> tuple[Path, str] | None:
    """A top-level JSON record of ``folder`` whose provenance header names a run, and
    that run id (None: no record names one, a folder written before run ids)."""
    for path in sorted(folder.glob("*.json")):
        if path.name == RUN_FILE or not path.is_file():
            continue
        try:
            doc = read_json(path, what="stage record")
        except InputError:
            continue  # not a record: the stage's own reader says what is wrong with it
        header = doc.get(HEADER_KEY) if isinstance(doc, dict) else None
        if isinstance(header, dict) and isinstance(header.get("run_id"), str):
            return path, header["run_id"]
    return None


def check_output_folder(folder: str | Path) -> str | None:
    """Verify that a stage's output folder is the whole output of one run.

    Parameters
    ----------
    folder : str or Path
        The folder a stage wrote.

    Returns
    -------
    str or None
        The run id; None for a folder written before run ids (no ``run.json`` and no
        record naming a run), which is read as before.

    Raises
    ------
    InputError
        A file ``run.json`` lists is missing or differs from its record, or a
        file it does not list is there (a mixed folder), naming the file; or
        ``run.json`` itself is missing while a record of the folder names its run.
    """
    folder = Path(folder)
    run = _run_of(folder)
    if run is None:
        recorded = _recorded_run(folder)
        if recorded is not None:
            raise InputError(folder / RUN_FILE, f"missing, while {recorded[0].name} records "
                             f"run {recorded[1]} (an altered folder)",
                             expected="the stage's whole output: run the stage that wrote "
                                      f"it again into {folder}")
        return None
    stage = run.get("stage", "?")
    record = f"{folder / RUN_FILE} of run {run['run_id']} (a mixed or altered folder)"
    repair = f"run bench {stage} again into {folder}"
    problems = [(folder / rel, recorded_mismatch(folder / rel, rec if isinstance(rec, dict)
                                                 else {}))
                for rel, rec in sorted(run["files"].items())]
    problems = [(p, w) for p, w in problems if w is not None]
    for path in _files(folder, tuple(run.get("kept") or ())):
        rel = path.relative_to(folder).as_posix()
        if rel != RUN_FILE and rel not in run["files"]:
            problems.append((path, "not written by this run"))
    raise_mismatches(problems, record, repair)
    return run["run_id"]


def check_output_file(path: str | Path) -> str | None:
    """:func:`check_output_folder` of the folder holding ``path`` (None: no run record)."""
    return check_output_folder(Path(path).parent)
