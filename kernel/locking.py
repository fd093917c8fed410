"""One writer at a time: an exclusive lock on a lock file holding the writer's pid.

The lock of the store's ingest (``<store>/.lock``) and of every stage's output
(``<parent>/.<name>.lock`` beside an output folder or file): ``flock`` on POSIX
(released when the process ends, however it ends), ``msvcrt.locking`` of the first
byte on Windows. A second writer waits, saying whom it waits for, or stops at once.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS


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


@contextlib.contextmanager
def output_lock(target: str | Path, stage: str, wait: bool = True,
                notify: Callable[[str], None] | None = None,
                option: str = "--out") -> Iterator[None]:
    """Hold the writer's lock of an output folder or file ``target`` for the block.

    The lock file is ``<parent>/.<name>.lock`` (the output itself is replaced whole,
    so the lock cannot live inside it).

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
    """
    import sys

    target = Path(target).absolute()
    notify = notify or (lambda msg: print(msg, file=sys.stderr, flush=True))
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(target.parent / f".{target.name}.lock", os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        reason = WRITE_ERRNOS.get(exc.errno, exc.strerror or str(exc))
        raise InputError(target, f"cannot write beside it ({reason})", column=option,
                         expected="a writable folder") from exc
    try:
        try:
            lock_fd(fd, block=False)
        except BlockingIOError as busy:
            holder = read_holder(fd).strip() or "?"
            if not wait:
                raise OutputBusy(target, f"another process (pid {holder}) is writing it",
                                 column=option, expected=f"one bench {stage} per output at a "
                                 "time") from busy
            notify(f"bench {stage}: waiting for another process (pid {holder}) writing "
                   f"{target} ...")
            lock_fd(fd, block=True)
        write_pid(fd)
        yield
    finally:
        os.close(fd)  # closing drops the lock
