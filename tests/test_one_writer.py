"""One writer per output (issue 26 §2): ``render``, ``merge``, ``scenarios build`` and the grasp commands
refuse a second process on the same ``--out`` (grasp file) with one ``error:`` line, and a holder killed with
``kill -9`` leaves no stale lock. Two real processes each time: a holder that takes the very lock the command
takes (:func:`mgdata.lock.output_lock`) and the real ``mgdata`` command. (``eval``: tests/evaluate/.)"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from mgdata.errors import OutputError
from mgdata.lock import FileLock, lock_path, output_lock

MGDATA = str(Path(sys.executable).parent / "mgdata")
HOLD = ("import sys; from pathlib import Path; from mgdata.lock import output_lock\n"
        "with output_lock(Path(sys.argv[1])):\n    print('held', flush=True); sys.stdin.read()\n")


@pytest.fixture()
def holder(tmp_path: Path) -> Iterator[callable]:
    procs: list[subprocess.Popen] = []

    def hold(out: Path) -> subprocess.Popen:
        proc = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, text=True)
        assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
        procs.append(proc)
        return proc

    yield hold
    for proc in procs:
        proc.kill()
        proc.wait()


def mgdata(*args: object) -> subprocess.CompletedProcess:
    return subprocess.run([MGDATA, *map(str, args)], capture_output=True, text=True, timeout=300,
                          env=os.environ | {"LP_NUM_THREADS": "1"})


def refused(proc: subprocess.CompletedProcess, out: Path) -> None:
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines == [f"error: --out {out}: open for writing by another process (one writer per output; "
                     "wait for it to finish or stop it)"], proc.stderr


COMMANDS = {
    "render": lambda tmp, out: ("render", tmp / "no-such-dataset", "--out", out),
    "merge": lambda tmp, out: ("merge", tmp / "no-such-shard", "--out", out),  # a folder, not a dataset
    "scenarios build": lambda tmp, out: ("scenarios", "build", "--out", out, "--family", "jar",
                                         "--tasks", "0", "--condition", "base"),
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_second_writer_is_refused_and_a_killed_one_leaves_no_lock(command: str, tmp_path: Path,
                                                                     holder: callable) -> None:
    out = tmp_path / "out"
    (tmp_path / "no-such-shard").mkdir()
    first = holder(out)
    refused(mgdata(*COMMANDS[command](tmp_path, out)), out)
    assert not out.exists()  # nothing written by the refused process
    first.send_signal(signal.SIGKILL)
    first.wait()
    assert lock_path(out).exists()  # the killed holder could not remove its file …
    again = mgdata(*COMMANDS[command](tmp_path, out))
    assert "another process" not in again.stderr, again.stderr  # … yet the lock died with it
    if command == "scenarios build":
        assert again.returncode == 0, again.stderr
        assert (out / "manifest.json").exists()
    else:  # past the lock, the command reports its own (missing) input
        assert again.returncode == 2 and "no-such" in again.stderr, again.stderr
    assert not lock_path(out).exists()  # a command that ends removes its lock file


def test_grasp_commands_take_one_writer_per_category_file(tmp_path: Path, holder: callable) -> None:
    # a validate overwriting a generate's file of the same category lost the generate's work (seen while
    # regenerating plates); runs on different categories still go side by side
    db = tmp_path / "grasps"
    assert mgdata("grasps", "generate", "jar/hinged_05", "--dir", db).returncode == 0
    before = (db / "jar.json").read_bytes()
    first = holder(db / "jar.json")
    for args in (("generate", "jar/hinged_05"), ("validate", "jar/hinged_05")):
        proc = mgdata("grasps", *args, "--dir", db)
        assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
        assert proc.stderr.strip().splitlines() == [
            f"error: grasp file {db / 'jar.json'}: open for writing by another process (one writer per "
            "output; wait for it to finish or stop it)"]
    assert (db / "jar.json").read_bytes() == before
    other = mgdata("grasps", "generate", "sponge/block_00", "--dir", db)
    assert other.returncode == 0 and (db / "sponge.json").exists(), other.stderr
    first.send_signal(signal.SIGKILL)
    first.wait()
    assert mgdata("grasps", "generate", "jar/hinged_05", "--dir", db).returncode == 0
    assert sorted(p.name for p in db.iterdir()) == ["jar.json", "sponge.json"]  # the killed one's lock: gone


def test_the_lock_is_exclusive_within_a_process_too(tmp_path: Path) -> None:
    out = tmp_path / "x"
    with output_lock(out), pytest.raises(OutputError, match="open for writing by another process"):
        FileLock(lock_path(out), f"--out {out}: open for writing by another process")
    assert not lock_path(out).exists()
    with output_lock(out):  # free again
        pass
