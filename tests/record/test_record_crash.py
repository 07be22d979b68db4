"""Crash safety with real SIGKILLs: an episode is entirely in the dataset or not at all, and resume continues.

A child process writes synthetic episodes (episode ``k`` is always the same, whatever run writes it), so a
dataset written across any number of kills and resumes must equal, byte for byte, one written in one go.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mgdata.record.commit import FileView
from mgdata.record.reader import DatasetReader
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from tests.helpers.record import tree_digest, write_episodes

SCHEMA = synthetic_schema(cameras=("front", "wrist", "left"), size=64)

CHILD = """
import os, signal, sys
from pathlib import Path
from mgdata.record import commit
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.writer import DatasetWriter

root, mode = Path(sys.argv[1]), sys.argv[2]
schema = synthetic_schema(cameras=("front", "wrist", "left"), size=64)
if mode.startswith("die-after-commit-point"):
    real_commit, count = commit.Transaction.commit, [0]
    def commit_then_die(tx):
        count[0] += 1
        if count[0] < 3:
            return real_commit(tx)
        tx.prepare()                       # the commit point: the manifest exists
        if mode.endswith("partial"):       # and some files are already installed
            rel, tmp = next(iter(tx.files.items()))
            os.replace(tmp, root / rel)
        os.kill(os.getpid(), signal.SIGKILL)
    commit.Transaction.commit = commit_then_die
writer = DatasetWriter.open_or_create(root, schema, spec=SYNTHETIC_SPEC)
print("opened", flush=True)
start = writer.num_episodes
for k in range(start, start + 1000):
    ep = synthetic_episode(schema, 20 + k % 7, seed=k, draw_index=k)
    for t, frame in enumerate(ep.frames()):
        writer.add_frame(frame)
        if mode == "handshake" and k == start + 2 and t == 10:
            print("mid-episode", flush=True)
            sys.stdin.readline()           # hold still until killed
    writer.end_episode(ep.meta)
    print("committed", k, flush=True)
"""


def _child(root: Path, mode: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", CHILD, str(root), mode], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _episode(k: int):
    return synthetic_episode(SCHEMA, 20 + k % 7, seed=k, draw_index=k)


def _clean_write(root: Path, n: int) -> Path:
    with DatasetWriter.create(root, SCHEMA, spec=SYNTHETIC_SPEC) as writer:
        write_episodes(writer, [_episode(k) for k in range(n)])
    return root


def test_kill_mid_episode_then_validate_and_resume(tmp_path: Path) -> None:
    root = tmp_path / "ds"
    child = _child(root, "handshake")
    lines = []
    while not lines or lines[-1] != "mid-episode":
        line = child.stdout.readline().strip()
        assert line, child.stderr.read()
        lines.append(line)
    child.send_signal(signal.SIGKILL)
    assert child.wait(30) == -signal.SIGKILL
    assert lines == ["opened", "committed 0", "committed 1", "mid-episode"]

    report = validate_dataset(root)
    assert report.ok, report.problems
    assert report.episodes == 2 and any("staging" in n for n in report.notes)
    reader = DatasetReader(root)
    np.testing.assert_array_equal(reader.episode(1).labels, _episode(1).labels)

    with DatasetWriter.open(root, SCHEMA) as writer:  # resume: drops the half episode, continues
        assert writer.num_episodes == 2
        write_episodes(writer, [_episode(2), _episode(3)])
    assert validate_dataset(root).ok
    assert tree_digest(root) == tree_digest(_clean_write(tmp_path / "clean", 4))


@pytest.mark.parametrize("mode", ["die-after-commit-point", "die-after-commit-point-partial"])
def test_kill_between_commit_point_and_install(tmp_path: Path, mode: str) -> None:
    root = tmp_path / "ds"
    child = _child(root, mode)
    out, err = child.communicate(timeout=60)
    assert child.returncode == -signal.SIGKILL, err
    # the 2nd episode's commit point was reached, then death
    assert out.split("\n")[:-1] == ["opened", "committed 0"]
    view = FileView(root)
    assert view.pending_commit
    report = validate_dataset(root)  # read-only: sees the committed state through the manifest
    assert report.ok, report.problems
    assert report.episodes == 2 and any("not yet installed" in n for n in report.notes)
    with DatasetWriter.open(root, SCHEMA) as writer:  # rolls the commit forward
        assert writer.num_episodes == 2
    assert not FileView(root).pending_commit and validate_dataset(root).ok
    assert tree_digest(root) == tree_digest(_clean_write(tmp_path / "clean", 2))


def _kill_and_resume(tmp_path: Path, kills: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    root = tmp_path / "ds"
    for _ in range(kills):
        child = _child(root, "free")
        assert child.stdout.readline() == "opened\n"  # kill while writing, not while importing
        time.sleep(rng.uniform(0.3, 1.5))
        os.kill(child.pid, signal.SIGKILL)
        child.communicate(timeout=30)
        report = validate_dataset(root)
        assert report.ok, report.problems
    with DatasetWriter.open(root, SCHEMA) as writer:
        n = writer.num_episodes
    assert n > 0
    assert tree_digest(root) == tree_digest(_clean_write(tmp_path / "clean", n))


def test_random_kills_never_leave_a_broken_dataset(tmp_path: Path) -> None:
    _kill_and_resume(tmp_path, kills=3, seed=0)


@pytest.mark.slow
def test_many_random_kills(tmp_path: Path) -> None:
    _kill_and_resume(tmp_path, kills=25, seed=1)
