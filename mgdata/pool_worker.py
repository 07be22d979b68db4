"""A process-pool worker (generation, scenario builds and checks, evaluation) never outlives the main process.

A main process killed outright (``kill -9``, or ``SIGTERM``, which Python does not catch) cannot stop its
pool: its workers would go on simulating, rendering and writing for a run that has ended. So each worker asks
the kernel to kill it when the main process dies (Linux ``PR_SET_PDEATHSIG``) and, where that is not
available, checks every ``WATCH_S`` that the main process is still its parent. (Ctrl-C reaches the whole
process group; what a worker does with it is its pool's choice.)

Example::

    ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                        initializer=die_with_parent, initargs=(os.getpid(),))
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time

WATCH_S = 0.5
"""Seconds between checks that the main process is alive (where the kernel cannot be asked)."""

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """In a worker started by process ``parent``: end when ``parent`` is gone."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
            if os.getppid() != parent:  # it died before the request: nobody will send the signal
                os._exit(1)
            return
    threading.Thread(target=_watch, args=(parent,), name="parent-watch", daemon=True).start()


def _watch(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(WATCH_S)
    os._exit(1)
