"""Real-time scheduling for the session loop on a loaded host (Linux ``SCHED_FIFO``).

:func:`realtime` puts the calling thread (the control loop) at ``priority`` and every other thread of the
process (the GL rasteriser, the operator view's publisher and server) one below it, so the loop wakes on time
and preempts its own helpers, and none of them waits behind other processes' work. Helper processes (the
leader reader) run one *above* the loop: a read takes ~1 ms of CPU every ~8 ms, and a reader held up behind
the loop's 30 ms camera render misses its servos' reply window (a failed read, a retry and a 50 ms drain).
Threads created later inherit their creator's policy. It needs ``CAP_SYS_NICE`` (root); without it the
request is an error, never silently ignored. The kernel's real-time throttling (by default 95 % of each
second) keeps a runaway thread from locking a core.

Example::

    with realtime(10):
        session_loop()
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path

from mgdata.errors import RecipeError


def _threads(pid: int | str = "self") -> list[int]:
    try:
        return [int(t.name) for t in Path(f"/proc/{pid}/task").iterdir()]
    except FileNotFoundError:  # the process ended
        return []


@contextlib.contextmanager
def realtime(priority: int, helpers: Iterable[int] = ()) -> Iterator[None]:
    """``SCHED_FIFO`` at ``priority`` (2 … 98) for this thread, ``priority - 1`` for its other threads and
    ``priority + 1`` for the threads of the ``helpers`` processes (pids), restored on exit. ``priority`` 0
    leaves scheduling alone."""
    if priority == 0:
        yield
        return
    if not 2 <= priority <= 98:
        raise RecipeError(f"[loop] realtime_priority = {priority}: must be 0 (off) or 2 … 98")
    me = threading.get_native_id()
    saved: dict[int, tuple[int, int]] = {}
    helpers = tuple(helpers)

    def everyone() -> dict[int, int]:
        """Thread id -> its priority."""
        prios = {tid: priority if tid == me else priority - 1 for tid in _threads()}
        return prios | {tid: priority + 1 for pid in helpers for tid in _threads(pid)}

    try:
        for tid, prio in everyone().items():
            try:
                saved[tid] = (os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority)
                os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(prio))
            except ProcessLookupError:  # the thread ended meanwhile
                continue
            except PermissionError as err:
                raise RecipeError(f"[loop] realtime_priority = {priority} needs CAP_SYS_NICE (root), which "
                                  "this process lacks; set it to 0") from err
        yield
    finally:
        for tid in everyone():  # threads started meanwhile go back to the default policy too
            policy, prio = saved.get(tid, (os.SCHED_OTHER, 0))
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.sched_setscheduler(tid, policy, os.sched_param(prio))
