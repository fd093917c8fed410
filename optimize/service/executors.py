"""Executors for the sweep: a local process pool or a Dask cluster, plus progress.

Any :class:`concurrent.futures.Executor` runs the sweep; each chain or step of the
start graph is one task (:func:`run_tasks`, :func:`run_graph`).
:func:`open_executor` makes the two supported ones:

* a :class:`~concurrent.futures.ProcessPoolExecutor` with ``workers`` processes
  (``spawn`` start method: CasADi/IPOPT and the tqdm thread of the parent are
  not fork-safe), its workers and the progress queue's manager each ended when
  the process that started them dies (:func:`kernel.lifetime.die_with_parent`); a
  worker whose solver call hangs ends itself at the call's hard stop
  (:func:`optimize.problem.deadline.hard_stop`), which breaks the pool: the run then
  stops with a :class:`WorkerLost` (a :class:`ClusterLost`), what finished kept as below;
* with ``scheduler`` given, the executor of a ``distributed.Client`` connected to
  that Dask scheduler address (optional extra ``drivebench[dask]``). Start the
  Dask workers with ``--nthreads 1``: one solve at a time per process (and then a worker
  whose solver call hangs ends itself at the call's hard stop, :func:`_on_worker`). An address
  that is none, or where no scheduler answers within 20 s, is refused; a cluster
  without a worker is waited for :data:`WORKER_WAIT_S` seconds, at the start and
  whenever its last worker leaves during the run, and then the run stops with an
  :class:`ClusterLost` (an :class:`~kernel.errors.InputError`) that says so
  (:class:`WatchedExecutor`), as when the scheduler stops answering. What finished is
  kept: the client's executor fetches each task's outcome as soon as it is done, and
  :func:`run_graph` hands the finished ones on with the error (``bench optimize`` writes
  its finished scenarios); the solves already stored are kept (``bench size`` and
  ``bench aep --refine`` store each as it finishes; a re-run takes them up).

Workers report progress through a *channel*: an object with ``put(dict)`` that
is shipped with the task, and ``drain()`` on the driver side. A
``multiprocessing`` manager queue serves the process pool, a
``distributed.Queue`` the Dask cluster, a plain queue in-process executors.
"""

from __future__ import annotations

import gc
import logging
import multiprocessing
import os
import queue
import sys
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.managers import SyncManager
from pathlib import Path
from typing import Any

from kernel.errors import InputError
from kernel.lifetime import die_with_parent
from optimize.problem.deadline import (
    HARD_STOP_CALLS,
    HARD_STOP_GRACE_S,
    arm_hard_stop,
    pool_worker,
)


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


#: how long a Dask cluster may have no worker, at the start or after its last worker
#: left, before the run stops [s]
WORKER_WAIT_S = 60.0
#: how often the driver asks the Dask scheduler for its workers during a run [s]
HEALTH_EVERY_S = 2.0
#: how long the scheduler may take to answer that question [s]
ANSWER_TIMEOUT_S = 10.0


class ClusterLost(InputError):
    """The Dask cluster can run nothing more: its scheduler stopped answering, or it has
    had no worker for :data:`WORKER_WAIT_S` seconds (:meth:`WatchedExecutor.check`).

    Attributes
    ----------
    why : str
        The loss in a few words (``--scheduler ADDRESS: it has had no worker for 61 s``),
        for the status of what it left unsolved.
    finished : dict of int to Future
        The tasks that had finished when the cluster was lost, by index, each holding its
        result or exception on this machine (set by :func:`run_graph`; empty elsewhere).
    """

    #: how the command says the loss; a loss the run decides itself (:class:`WorkerLost`,
    #: :class:`optimize.service.run.GaveUp`) has another, and a re-run may meet it again
    label = "CLUSTER LOST"

    def __init__(self, why: str, problem: str, expected: str) -> None:
        super().__init__(None, problem, expected=expected)
        self.why = why
        self.finished: dict[int, Future] = {}


class WorkerLost(ClusterLost):
    """A worker process of the local pool ended abruptly, which breaks the pool: a solver
    call that hung past its hard stop (:func:`optimize.problem.deadline.hard_stop`) ends
    its worker so, as does a worker killed from outside (out of memory, a signal). The
    run stops with what finished, as for a lost cluster; a re-run may hang the same way,
    so the scenarios it left are not said to be solved by one."""

    label = "WORKER LOST"

    def __init__(self, exc: BaseException) -> None:
        super().__init__(
            "worker lost: a process of the local pool ended abruptly",
            f"a worker process ended abruptly ({type(exc).__name__}): a solver call still "
            f"running {HARD_STOP_CALLS} times --call-time-limit and {HARD_STOP_GRACE_S:g} s "
            "after it began is taken to hang, and its worker is ended so (a worker killed "
            "from outside, out of memory or by a signal, ends the same way); the run stops, "
            "nothing more is solved: what finished is kept",
            expected="solver calls that end at their --call-time-limit")


def _on_worker(driver_pid: int, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)`` on a Dask worker; one that is a process of its own (not the
    driver's, ``driver_pid``: an in-process cluster) and runs one task at a time
    (``--nthreads 1``) ends itself at a hung solver call's hard stop
    (:func:`optimize.problem.deadline.arm_hard_stop`): its nanny starts it again and the
    scheduler gives the task to a worker again, up to its allowed failures (3 by default),
    then fails it (``worker error: KilledWorker``)."""
    from distributed import get_worker

    if os.getpid() != driver_pid and get_worker().state.nthreads == 1:
        arm_hard_stop()
    return fn(*args, **kwargs)


def _lost_worker(futures: dict[int, Future]) -> WorkerLost | None:
    """The loss of a local pool whose worker ended abruptly (a future that holds a
    :class:`~concurrent.futures.process.BrokenProcessPool`), or None."""
    for f in futures.values():
        if f.done() and not f.cancelled() and isinstance(f.exception(), BrokenProcessPool):
            return WorkerLost(f.exception())
    return None


class WatchedExecutor(Executor):
    """A Dask client's executor that can tell when it can no longer run anything.

    :func:`run_graph` calls :meth:`check` while it waits: it asks the scheduler for its
    workers (every :data:`HEALTH_EVERY_S` seconds) and raises when the scheduler does not
    answer (within :data:`ANSWER_TIMEOUT_S`), or has had no worker for ``wait_s`` seconds
    (default :data:`WORKER_WAIT_S`).
    """

    def __init__(self, client: Any, address: str, wait_s: float | None = None) -> None:
        self._client, self.address = client, address
        self.wait_s = WORKER_WAIT_S if wait_s is None else wait_s
        self._inner = client.get_executor(pure=False)
        self._asked = self._seen = time.monotonic()
        self.n_slots = 0
        self.lost: ClusterLost | None = None

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        """Submit ``fn(*args, **kwargs)`` to the cluster, its hung solver calls ended on a
        worker of its own (:func:`_on_worker`)."""
        return self._inner.submit(_on_worker, os.getpid(), fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Shut the client's executor down (the client is closed by :func:`open_executor`)."""
        self._inner.shutdown(wait=wait)

    def slots(self) -> int:
        """Threads of the cluster's workers now; raises when the scheduler does not answer."""
        try:
            n = sum(self._client.nthreads(callback_timeout=ANSWER_TIMEOUT_S).values())
        except Exception as exc:  # noqa: BLE001 - any failure to answer ends the run, said
            raise self._stopped(f"the scheduler no longer answers ({type(exc).__name__}: "
                                f"{exc})") from None
        if n:
            self._seen, self.n_slots = time.monotonic(), n
        return n

    def check(self, force: bool = False) -> None:
        """Raise :class:`~kernel.errors.InputError` when the cluster cannot run the tasks:
        the scheduler does not answer, or it has had no worker for :attr:`wait_s`
        seconds. Asks the scheduler at most every :data:`HEALTH_EVERY_S` seconds unless
        ``force``; once lost, raises at once on every later call (nothing is waited for
        twice)."""
        if self.lost is not None:
            raise self.lost
        now = time.monotonic()
        if not force and now - self._asked < HEALTH_EVERY_S:
            return
        self._asked = now
        if self.slots() == 0 and (force or now - self._seen > self.wait_s):
            raise self._stopped(f"it has had no worker for {now - self._seen:.0f} s",
                                f" (the last left during the run; waited up to "
                                f"{self.wait_s:g} s)")

    def _stopped(self, why: str, more: str = "") -> ClusterLost:
        """The loss, remembered: ``why`` in a few words, ``more`` said after it."""
        self.lost = ClusterLost(
            f"cluster lost: --scheduler {self.address}: {why}",
            f"--scheduler {self.address}: {why}{more}; the run stops, nothing more is solved: what "
            "finished is kept (bench optimize writes the scenarios that finished; bench size "
            "and bench aep --refine keep the solves already stored, and a re-run takes them "
            "up)", expected=f"a scheduler with workers: dask worker {self.address} "
            "--nthreads 1")
        return self.lost


def _address_problem(address: str) -> str | None:
    """What is wrong with a Dask scheduler address as text (no client is made for it),
    or None: an unknown scheme, a host or port that cannot be read, a port out of range."""
    from distributed.comm import parse_address
    from distributed.comm.registry import backends

    try:
        scheme, location = parse_address(address)
        backend = backends[scheme]
    except KeyError as exc:
        return f"unknown scheme {exc} (known: {', '.join(sorted(backends))})"
    except (ValueError, TypeError) as exc:
        return f"{type(exc).__name__}: {exc}"
    try:
        _, port = backend.get_address_host_port(location)
    except NotImplementedError:  # an in-process address has no host and port
        return None
    except (ValueError, TypeError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None if 0 < int(port) < 65536 else f"port {port} is outside 1 to 65535"


def _dask_client(scheduler: str) -> Any:
    """A client of the scheduler at ``scheduler``; InputError when the address is none or
    no scheduler answers there within 20 s."""
    try:
        from distributed import Client
    except ImportError as exc:
        raise InputError(
            None,
            f"--scheduler {scheduler!r}: the Dask extra is not installed",
            expected="pip install 'drivebench[dask]'",
        ) from exc
    expected = "the address of a running Dask scheduler, e.g. tcp://host:8786"
    problem = _address_problem(scheduler)
    if problem is not None:
        raise InputError(None, f"--scheduler {scheduler!r}: not a scheduler address "
                         f"({problem})", expected=expected)
    try:
        return Client(scheduler, timeout="20s")
    except Exception as exc:  # noqa: BLE001 - none answering, a handshake refused, ...
        why = f"cannot connect ({type(exc).__name__}: {exc})"
    # the half-made client is freed now: freed later, inside another client's start, its
    # __del__ waits on a lock that start holds (distributed deadlocks)
    gc.collect()
    raise InputError(None, f"--scheduler {scheduler!r}: {why}", expected=expected)


def _wait_for_workers(client: Any, scheduler: str, wait_s: float) -> None:
    """Wait up to ``wait_s`` seconds for the cluster's first worker; raise when none came."""
    try:
        client.wait_for_workers(1, timeout=wait_s)
    except Exception as exc:  # noqa: BLE001 - dask's TimeoutError, or the scheduler gone
        raise InputError(None, f"--scheduler {scheduler!r}: the scheduler has no worker "
                         f"(waited {wait_s:g} s; {type(exc).__name__}); nothing was solved",
                         expected=f"a scheduler with workers: dask worker {scheduler} "
                                  "--nthreads 1") from None


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
        If ``workers`` < 1, the Dask extra is missing, the address is none, no scheduler
        answers there, or it has no worker within :data:`WORKER_WAIT_S` seconds.
    """
    if scheduler:
        client = _dask_client(scheduler)
        # a lost scheduler is said once, as ClusterLost; the client's own reconnect errors
        # (tracebacks of cancelled tasks) would say it again
        client_log = logging.getLogger("distributed.client")
        level = client_log.level
        client_log.setLevel(logging.CRITICAL)
        try:
            _wait_for_workers(client, scheduler, WORKER_WAIT_S)
            executor = WatchedExecutor(client, scheduler)
            n = max(1, executor.slots())
            channel = DaskChannel(f"drivebench-progress-{uuid.uuid4().hex}", client)
            description = f"dask scheduler {scheduler}, {n} slots"
            yield ExecutorHandle(executor, channel, description, n)
        finally:
            client.close()
            client_log.setLevel(level)
        return
    if workers < 1:
        raise InputError(None, f"--workers {workers}: not >= 1", expected="a positive integer")
    ctx = multiprocessing.get_context("spawn")
    manager = SyncManager(ctx=ctx)
    with _main_not_reimported():
        manager.start(die_with_parent, (os.getpid(),))
        with manager, ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                          initializer=pool_worker,
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
    stop: Callable[[dict[int, Future]], ClusterLost | None] | None = None,
) -> dict[int, Future]:
    """Run ``n`` dependent tasks: task ``i`` is submitted as ``fn(make_task(i, done),
    progress=channel)`` once every task of ``needs(i)`` has finished (``done``: their
    futures, by index), ready tasks in index order; relay progress until all finish.

    ``needs`` must only name lower indices (the tasks in a topological order). The
    other parameters are those of :func:`run_tasks`. Returns every future by index, all
    done; a task's exception stays in its future (its dependents still run). ``stop``
    (the finished tasks' futures -> a reason to submit no more, or None) is asked as
    tasks finish; once it gives one, the tasks running then finish and it is raised.

    Raises
    ------
    ClusterLost
        The executor can no longer run the tasks (:meth:`WatchedExecutor.check`: a Dask
        cluster without workers or scheduler; :class:`WorkerLost`: a local pool whose
        worker ended abruptly); its ``finished`` holds the tasks done by then.
    InputError
        The executor cancelled some tasks.
    """
    futures: dict[int, Future] = {}
    try:
        _run_graph(executor, fn, n, needs, make_task, channel, on_event, poll_s, futures,
                   stop)
    except ClusterLost as exc:
        exc.finished = {i: f for i, f in futures.items() if f.done() and not f.cancelled()}
        raise
    return futures


def _drain(channel: Any, on_event: Callable[[dict], None] | None,
           check: Callable[..., None] | None) -> None:
    """Hand the channel's events to ``on_event``; a channel that fails (a Dask queue whose
    scheduler is gone) is the cluster's loss, said as such by ``check``."""
    if channel is None or on_event is None:
        return
    try:
        events = channel.drain()
    except OSError:
        if check is not None:
            check(force=True)
        raise
    for event in events:
        on_event(event)


def _run_graph(executor: Executor, fn: Callable[..., Any], n: int,
               needs: Callable[[int], Sequence[int]],
               make_task: Callable[[int, dict[int, Future]], Any], channel: Any,
               on_event: Callable[[dict], None] | None, poll_s: float,
               futures: dict[int, Future],
               stop: Callable[[dict[int, Future]], ClusterLost | None] | None) -> None:
    """:func:`run_graph`'s loop, filling ``futures``."""
    waiting = list(range(n))
    check = getattr(executor, "check", None)  # a cluster that can stop running (Dask)
    stopped = None
    while waiting or any(not f.done() for f in futures.values()):
        if check is not None:
            check()
        done = {i: f for i, f in futures.items() if f.done()}
        lost = _lost_worker(done)
        if lost is not None:
            _drain(channel, on_event, check)
            raise lost
        if stop is not None and stopped is None:
            stopped = stop(done)
            waiting = [] if stopped is not None else waiting
        ready = [i for i in waiting if all(j in done for j in needs(i))]
        for i in ready:
            try:
                futures[i] = executor.submit(fn, make_task(i, done), progress=channel)
            except BrokenProcessPool as exc:  # broken between the look and the submit
                raise WorkerLost(exc) from None
        waiting = [i for i in waiting if i not in ready]
        pending = [f for f in futures.values() if not f.done()]
        if waiting and not pending and not ready:
            raise ValueError(f"tasks {waiting} need tasks that come after them")
        if pending:
            wait(pending, timeout=poll_s, return_when=FIRST_COMPLETED)
        _drain(channel, on_event, check)
    _drain(channel, on_event, check)
    lost = _lost_worker(futures) or stopped
    if lost is not None:
        raise lost
    cancelled = sorted(i for i, f in futures.items() if f.cancelled())
    if cancelled:  # the executor shut down under them (a Dask client closed)
        if check is not None:
            check(force=True)
        raise InputError(None, f"{len(cancelled)} of {n} tasks were cancelled: the executor "
                         "stopped during the run; nothing more is solved")
