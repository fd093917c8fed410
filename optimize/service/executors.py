"""Executors for the sweep: a local process pool or a Dask cluster, plus progress.

Any :class:`concurrent.futures.Executor` runs the sweep; each chain or step of the
start graph is one task (:func:`run_tasks`, :func:`run_graph`).
:func:`open_executor` makes the two supported ones:

* a :class:`~concurrent.futures.ProcessPoolExecutor` with ``workers`` processes
  (``spawn`` start method: CasADi/IPOPT and the tqdm thread of the parent are
  not fork-safe), its workers and the progress queue's manager each ended when
  the process that started them dies (:func:`kernel.lifetime.die_with_parent`);
* with ``scheduler`` given, the executor of a ``distributed.Client`` connected to
  that Dask scheduler address (optional extra ``drivebench[dask]``). Start the
  Dask workers with ``--nthreads 1``: one solve at a time per process.

Workers report progress through a *channel*: an object with ``put(dict)`` that
is shipped with the task, and ``drain()`` on the driver side. A
``multiprocessing`` manager queue serves the process pool, a
``distributed.Queue`` the Dask cluster, a plain queue in-process executors.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import sys
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.managers import SyncManager
from pathlib import Path
from typing import Any

from kernel.errors import InputError
from kernel.lifetime import die_with_parent


class QueueChannel:
    """Progress channel over a queue shared by the driver and its tasks.

    Parameters
    ----------
    q : queue-like, optional
        A ``multiprocessing`` manager queue proxy (picklable) for process pools;
        by default a ``queue.Queue``, for executors that share the driver's
        memory (threads).
    """

    def __init__(self, q: Any | None = None) -> None:
        self._queue = queue.Queue() if q is None else q

    def put(self, item: dict) -> None:
        """Called by a task (in any thread or worker process): report one event."""
        self._queue.put(item)

    def drain(self) -> list[dict]:
        """Called by the driver: every event reported so far."""
        items = []
        while True:
            try:
                items.append(self._queue.get_nowait())
            except queue.Empty:
                return items


class DaskChannel:
    """Progress channel over a named ``distributed.Queue`` (re-attached on each worker)."""

    def __init__(self, name: str, client: Any = None) -> None:
        self.name = name
        self._client = client

    def __getstate__(self) -> dict:
        return {"name": self.name}

    def __setstate__(self, state: dict) -> None:
        self.name = state["name"]
        self._client = None

    def _queue(self) -> Any:
        from distributed import Queue

        return Queue(self.name, client=self._client)

    def put(self, item: dict) -> None:
        """Called by a task on a Dask worker."""
        self._queue().put(item)

    def drain(self) -> list[dict]:
        """Called by the driver."""
        q = self._queue()
        return list(q.get(batch=True)) if q.qsize() else []


@dataclass
class ExecutorHandle:
    """An open executor with its progress channel.

    Attributes
    ----------
    executor : Executor
    channel : QueueChannel or DaskChannel
    description : str
        For logs and the manifest, e.g. ``"process pool, 2 workers"``.
    n_workers : int
        Number of tasks that can run at the same time.
    """

    executor: Executor
    channel: Any
    description: str
    n_workers: int


def _dask_client(scheduler: str) -> Any:
    try:
        from distributed import Client
    except ImportError as exc:
        raise InputError(
            None,
            f"--scheduler {scheduler!r}: the Dask extra is not installed",
            expected="pip install 'drivebench[dask]'",
        ) from exc
    try:
        return Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise InputError(
            None,
            f"--scheduler {scheduler!r}: cannot connect ({exc})",
            expected="the address of a running Dask scheduler, e.g. tcp://host:8786",
        ) from exc


@contextmanager
def _main_not_reimported() -> Iterator[None]:
    """While open, spawned processes do not re-import a ``__main__`` that is no file.

    A ``spawn`` child runs the parent's ``__main__`` file again (scripts need their
    ``if __name__ == "__main__":`` guard); code read from standard input or typed at
    a prompt has no file (``<stdin>``), so the child would fail with FileNotFoundError.
    The tasks are functions of drivebench's own modules and need nothing from
    ``__main__``, so a ``__main__`` without a file is left out, as for an interactive
    session.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is None or Path(path).is_file():
        yield
        return
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path


@contextmanager
def open_executor(workers: int = 2, scheduler: str | None = None) -> Iterator[ExecutorHandle]:
    """Open the sweep's executor; closes it (and its channel) on exit.

    Parameters
    ----------
    workers : int
        Size of the local process pool (ignored with ``scheduler``); >= 1.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``).

    Yields
    ------
    ExecutorHandle

    Raises
    ------
    InputError
        If ``workers`` < 1, the Dask extra is missing or the scheduler is unreachable.
    """
    if scheduler:
        client = _dask_client(scheduler)
        try:
            n = max(1, sum(client.nthreads().values()))
            channel = DaskChannel(f"drivebench-progress-{uuid.uuid4().hex}", client)
            description = f"dask scheduler {scheduler}, {n} slots"
            yield ExecutorHandle(client.get_executor(pure=False), channel, description, n)
        finally:
            client.close()
        return
    if workers < 1:
        raise InputError(None, f"--workers {workers}: not >= 1", expected="a positive integer")
    ctx = multiprocessing.get_context("spawn")
    manager = SyncManager(ctx=ctx)
    with _main_not_reimported():
        manager.start(die_with_parent, (os.getpid(),))
        with manager, ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                          initializer=die_with_parent,
                                          initargs=(os.getpid(),)) as ex:
            plural = "s" if workers > 1 else ""
            yield ExecutorHandle(ex, QueueChannel(manager.Queue()),
                                 f"process pool, {workers} worker{plural}", workers)


def run_tasks(
    executor: Executor,
    fn: Callable[..., Any],
    tasks: Sequence[Any],
    channel: Any = None,
    on_event: Callable[[dict], None] | None = None,
    poll_s: float = 0.25,
) -> list[Future]:
    """Submit ``fn(task, progress=channel)`` for every task; relay progress until all finish.

    Parameters
    ----------
    executor : Executor
        Any ``concurrent.futures`` executor.
    fn : callable
        Module-level (picklable) function run on the worker.
    tasks : sequence
        One argument per task.
    channel : optional
        Progress channel passed to ``fn`` as ``progress``; drained every
        ``poll_s`` seconds into ``on_event``.
    on_event : callable, optional
        Receives each progress event (a dict) in the driver.
    poll_s : float
        Polling period [s].

    Returns
    -------
    list of Future
        In task order, all done; a task's exception stays in its future.
    """
    futures = run_graph(executor, fn, len(tasks), lambda i: (), lambda i, done: tasks[i],
                        channel, on_event, poll_s)
    return [futures[i] for i in range(len(tasks))]


def run_graph(
    executor: Executor,
    fn: Callable[..., Any],
    n: int,
    needs: Callable[[int], Sequence[int]],
    make_task: Callable[[int, dict[int, Future]], Any],
    channel: Any = None,
    on_event: Callable[[dict], None] | None = None,
    poll_s: float = 0.25,
) -> dict[int, Future]:
    """Run ``n`` dependent tasks: task ``i`` is submitted as ``fn(make_task(i, done),
    progress=channel)`` once every task of ``needs(i)`` has finished (``done``: their
    futures, by index), ready tasks in index order; relay progress until all finish.

    ``needs`` must only name lower indices (the tasks in a topological order). The
    other parameters are those of :func:`run_tasks`. Returns every future by index, all
    done; a task's exception stays in its future (its dependents still run).
    """
    futures: dict[int, Future] = {}
    waiting = list(range(n))
    while waiting or any(not f.done() for f in futures.values()):
        done = {i: f for i, f in futures.items() if f.done()}
        ready = [i for i in waiting if all(j in done for j in needs(i))]
        for i in ready:
            futures[i] = executor.submit(fn, make_task(i, done), progress=channel)
        waiting = [i for i in waiting if i not in ready]
        pending = [f for f in futures.values() if not f.done()]
        if waiting and not pending and not ready:
            raise ValueError(f"tasks {waiting} need tasks that come after them")
        if pending:
            wait(pending, timeout=poll_s, return_when=FIRST_COMPLETED)
        if channel is not None and on_event is not None:
            for event in channel.drain():
                on_event(event)
    if channel is not None and on_event is not None:
        for event in channel.drain():
            on_event(event)
    return futures
