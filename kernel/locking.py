"""One writer at a time: an exclusive lock on a lock file holding the writer's pid.

The lock of the store's ingest (``<store>/.lock``) and of every stage's output
(``<parent>/.<name>.lock`` beside an output folder or file, removed by its holder when
done): ``flock`` on POSIX (released when the process ends, however it ends),
``msvcrt.locking`` of the first byte on Windows. A second writer waits, saying whom it
waits for, or stops at once.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS
from kernel.output_place import check_place


def lock_fd(fd: int, block: bool) -> None:
    """Exclusive lock on an open file; BlockingIOError when taken and ``block`` is False."""
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


def read_holder(fd: int) -> str:
    """The text at the start of the lock file (the holder's pid), without the lock."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, 64).decode("ascii", "replace")
    except OSError:  # Windows: the locked byte cannot be read
        return ""


def write_pid(fd: int) -> None:
    """Write this process's pid into the (locked) lock file."""
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    os.write(fd, f"{os.getpid()}\n".encode())


class OutputBusy(InputError):
    """Another process writes the output and the caller chose not to wait."""


def _made_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; the folders created, deepest first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def _open_locked(path: Path, target: Path, stage: str, wait: bool,
                 notify: Callable[[str], None], option: str) -> int:
    """The lock file ``path`` opened and locked, the lock taken on the file that is at
    ``path`` now (the last holder removes it when done: whoever locked the removed one
    opens it again)."""
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            try:
                lock_fd(fd, block=False)
            except BlockingIOError as busy:
                holder = read_holder(fd).strip() or "?"
                if not wait:
                    raise OutputBusy(target, f"another process (pid {holder}) is writing it",
                                     column=option, expected=f"one bench {stage} per output "
                                     "at a time") from busy
                notify(f"bench {stage}: waiting for another process (pid {holder}) writing "
                       f"{target} ...")
                lock_fd(fd, block=True)
            try:
                same = os.fstat(fd).st_ino == os.stat(path).st_ino
            except FileNotFoundError:
                same = False
        except BaseException:
            os.close(fd)
            raise
        if same:
            return fd
        os.close(fd)


@contextlib.contextmanager
def output_lock(target: str | Path, stage: str, wait: bool = True,
                notify: Callable[[str], None] | None = None,
                option: str = "--out") -> Iterator[None]:
    """Hold the writer's lock of an output folder or file ``target`` for the block.

    The lock file is ``<parent>/.<name>.lock`` (the output itself is replaced whole,
    so the lock cannot live inside it); the holder removes it when done, so neither a
    finished nor a refused write leaves it behind, and a folder the lock had to create
    is removed again when the block fails and left it empty.

    Parameters
    ----------
    target : str or Path
        The output folder or file.
    stage : str
        The stage writing it, for the messages.
    wait : bool
        Wait for another writer (saying so through ``notify``) or raise
        :class:`OutputBusy` at once.
    notify : callable, optional
        Called with one line when waiting (default: print to stderr).
    option : str
        The option that named ``target``.

    Raises
    ------
    InputError
        ``target`` lies inside another stage's output or a store
        (:func:`kernel.output_place.check_place`), or its folder cannot be written.
    """
    import sys

    target = check_place(Path(target).absolute(), option)
    notify = notify or (lambda msg: print(msg, file=sys.stderr, flush=True))
    path = target.parent / f".{target.name}.lock"
    made: list[Path] = []
    try:
        made = _made_parents(target.parent)
        fd = _open_locked(path, target, stage, wait, notify, option)
    except OSError as exc:
        _remove_empty(made)
        reason = WRITE_ERRNOS.get(exc.errno, exc.strerror or str(exc))
        raise InputError(target, f"cannot write beside it ({reason})", column=option,
                         expected="a writable folder") from exc
    except BaseException:
        _remove_empty(made)
        raise
    try:
        write_pid(fd)
        yield
    except BaseException:
        _unlink(path)
        os.close(fd)
        _remove_empty(made)
        raise
    _unlink(path)
    os.close(fd)  # closing drops the lock


def _unlink(path: Path) -> None:
    """Remove the lock file while holding its lock (Windows: an open file stays)."""
    try:
        path.unlink()
    except OSError:
        pass


def _remove_empty(folders: list[Path]) -> None:
    """Remove the folders (deepest first) that are still empty."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            return
