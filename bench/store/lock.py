"""One writer at a time: an exclusive lock on ``<store>/.lock`` holding the writer's pid
(the flock of :mod:`kernel.locking`, which every stage's output uses too)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from bench.store.schema import LOCK_FILE
from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS
from kernel.locking import lock_fd, read_holder, write_pid
from kernel.output_place import check_place


class StoreBusy(InputError):
    """Another ingest holds the store's lock and the caller chose not to wait."""


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
            lock_fd(fd, block=False)
        except BlockingIOError as busy:
            holder = read_holder(fd).strip() or "?"
            if not self.wait:
                os.close(fd)
                raise StoreBusy(self.store,
                                f"another ingest (pid {holder}) is writing this store",
                                expected="one ingest per store at a time") from busy
            self.notify(f"bench ingest: waiting for another ingest (pid {holder}) "
                        f"writing {self.store} ...")
            lock_fd(fd, block=True)

    def acquire(self) -> None:
        """Take the lock and write this process's pid into the lock file."""
        check_place(self.store, "--store")  # not inside another stage's output or store
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
                write_pid(fd)
                return
            os.close(fd)

    def release(self) -> None:
        """Drop the lock (closing the file drops the flock)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
