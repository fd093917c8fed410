"""A child process that ends with the process that started it.

It lives in the kernel, away from the solve service, because a spawned child imports
the module of its initializer. The progress queue's manager runs nothing else; when
this function lived in ``optimize.service.executors`` the manager imported the whole
solve service first, and opening a pool of two workers cost 3.2 s of the children's
CPU and 0.8 s before it could be used, against 0.23 s and 0.08 s now
(``benchmarks/executor_start.py``, benchmarks/README.md).
"""

from __future__ import annotations

import ctypes
import os
import signal

#: Linux ``prctl`` option: the signal a process gets when the thread that started it ends
_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Process initializer: end this process when ``parent_pid``, the process that
    started it, dies. A killed ``bench`` left its idle workers running for good (each
    worker holds its own end of the task queue, so it never sees the queue close). Linux
    only (``prctl(PR_SET_PDEATHSIG)``); elsewhere nothing changes."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: no prctl
        return
    if os.getppid() != parent_pid:  # it died before the signal was armed
        os._exit(1)
