"""Helpers of the evaluation tests (a module of its own: every test folder has a ``conftest``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

MGDATA = [str(Path(sys.executable).parent / "mgdata")]
ENV = {**os.environ, "LP_NUM_THREADS": "1"}


def serve_process(*args: str) -> tuple[subprocess.Popen, str]:
    """``mgdata serve ARGS --port 0`` as a process; returns it and the URL it printed."""
    proc = subprocess.Popen([*MGDATA, "serve", *args, "--port", "0"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV)
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("serving "):
            return proc, line.split(" on ")[1].split()[0]
    proc.kill()
    raise AssertionError(f"mgdata serve did not start: {proc.stderr.read() if proc.stderr else ''}")
