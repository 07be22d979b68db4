"""teleop.priority: the session's threads and the leader reader's process run SCHED_FIFO while asked to,
and go back afterwards."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

import pytest

from mgdata.errors import RecipeError
from mgdata.teleop.config import LoopConfig
from mgdata.teleop.priority import realtime


def _policy(tid: int) -> tuple[int, int]:
    return os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority


def test_realtime_puts_the_loop_above_its_helpers_and_restores_them() -> None:
    release, started = threading.Event(), threading.Event()

    def helper() -> None:
        started.set()
        release.wait(10.0)

    t = threading.Thread(target=helper)
    t.start()
    started.wait(10.0)
    me, other = threading.get_native_id(), t.native_id
    assert other is not None
    helper_proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    before = _policy(me), _policy(other), _policy(helper_proc.pid)
    try:
        try:
            with realtime(7, helpers=(helper_proc.pid,)):
                # read back from the kernel, per thread: the loop above its own threads, the reader above both
                assert _policy(me) == (os.SCHED_FIFO, 7)
                assert _policy(other) == (os.SCHED_FIFO, 6)
                assert _policy(helper_proc.pid) == (os.SCHED_FIFO, 8)
        except RecipeError as err:  # not root: the request is refused loudly, nothing changed
            assert "CAP_SYS_NICE" in str(err)
        assert (_policy(me), _policy(other), _policy(helper_proc.pid)) == before
    finally:
        release.set()
        t.join()
        helper_proc.kill()
        helper_proc.wait()


def test_realtime_zero_changes_nothing_and_bad_priorities_are_errors() -> None:
    before = _policy(0)
    with realtime(0):
        assert _policy(0) == before
    for bad in (1, 99, -3):
        with pytest.raises(RecipeError, match="realtime_priority"), realtime(bad):
            pass
        with pytest.raises(RecipeError, match="realtime_priority"):
            LoopConfig(realtime_priority=bad)
