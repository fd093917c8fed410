"""One writer at a time: an exclusive lock on ``<store>/.lock`` holding the writer's pid."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from bench.store.schema import LOCK_FILE
from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS


class StoreBusy(InputError):
    """Another ingest holds the store's lock and the caller chose not to wait."""


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


class StoreLock:
    """The exclusive lock of one store's writer (creating the store when missing).

    Parameters
    ----------
    store : Path
        The store.
    wait : bool
        Wait for another writer (with a message) or raise :class:`StoreBusy` at once.
    notify : callable
        Called with one line when waiting.
    """

    def __init__(self, store: Path, wait: bool, notify: Callable[[str], None]) -> None:
        self.store = store
        self.wait = wait
        self.notify = notify
        #: True when :meth:`acquire` created the store folder
        self.created = False
        self._fd: int | None = None

    def _open(self) -> int | None:
        """The lock file opened (the store created when missing); None when the store
        vanished between its creation and the open."""
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
            return os.open(self.store / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o666)
        except FileNotFoundError:
            return None
        except OSError as exc:
            reason = WRITE_ERRNOS.get(exc.errno, exc.strerror or str(exc))
            raise InputError(self.store, f"cannot write to the store ({reason})",
                             expected="a writable store directory") from exc

    def _take(self, fd: int) -> None:
        """Lock ``fd``, waiting for the holder (or raising StoreBusy when not waiting)."""
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

    def acquire(self) -> None:
        """Take the lock and write this process's pid into the lock file."""
        lock_path = self.store / LOCK_FILE
        while True:
            fd = self._open()
            if fd is None:  # the store vanished between mkdir and open: retry
                continue
            self._take(fd)
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

    def release(self) -> None:
        """Drop the lock (closing the file drops the flock)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
