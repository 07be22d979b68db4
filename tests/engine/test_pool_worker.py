"""A pool's workers do not outlive a main process that is killed (``SIGTERM``, ``kill -9``): they would go on
building scenarios (or simulating attempts, or rollouts) for a run that has ended."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

MGDATA = [str(Path(sys.executable).parent / "mgdata")]


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid``, from /proc."""
    kids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:  # ended meanwhile
            continue
        if int(text.rsplit(")", 1)[1].split()[1]) == pid:
            kids.append(int(stat.parent.name))
    return kids


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_scenario_build_workers_end_with_a_killed_main_process(tmp_path: Path, sig: signal.Signals) -> None:
    env = dict(os.environ, LP_NUM_THREADS="1")
    cmd = [*MGDATA, "scenarios", "build", "--family", "jar", "--tasks", "0-5", "--workers", "2", "--out",
           str(tmp_path / "scen")]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        workers: list[int] = []
        while len(workers) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.2)  # the pool's two workers (and multiprocessing's resource tracker) appear
            workers = [k for k in _children(proc.pid) if "resource_tracker" not in
                       Path(f"/proc/{k}/cmdline").read_bytes().decode(errors="replace")]
        assert len(workers) >= 2, "the build never started its workers"
        time.sleep(1.0)  # they are at work
        os.kill(proc.pid, sig)
        proc.wait(timeout=30)
        deadline = time.monotonic() + 10
        while any(_alive(k) for k in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(_alive(k) for k in workers), "a worker outlived the killed main process"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
