"""``mgdata`` through its real entry point (:func:`mgdata.cli.main`) in the test's own process: for the
error paths of commands that refuse their input before doing any work, where a process of its own would
cost seconds of interpreter start-up and imports and prove nothing more (each file that uses this keeps a
case or more as a real ``mgdata`` process)."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys
from pathlib import Path

from mgdata import cli


def mgdata_here(*args: str | Path) -> subprocess.CompletedProcess:
    """Run ``mgdata ARGS`` in this process; its exit status, stdout and stderr as a ``CompletedProcess``."""
    argv = [str(a) for a in args]
    out, err = io.StringIO(), io.StringIO()
    saved = sys.argv
    sys.argv = ["mgdata", *argv]
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                cli.main()
                code = 0
            except SystemExit as exit_:
                code = exit_.code if isinstance(exit_.code, int) else (0 if exit_.code is None else 1)
    finally:
        sys.argv = saved
    return subprocess.CompletedProcess(["mgdata", *argv], code, out.getvalue(), err.getvalue())
