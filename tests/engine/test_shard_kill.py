"""``--shard i/N`` + ``mgdata merge`` when one shard's job is killed (issue 26 §1): shard 1's job is killed
with SIGKILL (it and its workers, as when its machine dies) in the middle of its attempt, re-run with the
same command, and the merge of the shards is byte-identical to one run over all tasks. Slow: four small
generate runs."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.helpers.generate import jar_recipe
from tests.helpers.record import dataset_files

pytestmark = pytest.mark.slow
MGDATA = str(Path(sys.executable).parent / "mgdata")
ENV = os.environ | {"LP_NUM_THREADS": "1"}



def test_a_killed_shard_job_is_rerun_and_the_merge_is_the_single_run(tmp_path: Path) -> None:
    recipe = jar_recipe(tmp_path)
    common = [MGDATA, "generate", "--family", "jar", "--recipe", str(recipe), "--per-task", "1", "--tasks",
              "0-1", "--workers", "2"]
    s0, s1 = tmp_path / "s0", tmp_path / "s1"
    done = subprocess.run([*common, "--shard", "0/2", "--out", str(s0)], capture_output=True, text=True,
                          timeout=1800, env=ENV)
    assert done.returncode == 0, done.stdout + done.stderr
    job = subprocess.Popen([*common, "--shard", "1/2", "--out", str(s1)], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, env=ENV, start_new_session=True)
    deadline = time.monotonic() + 600
    while not (s1 / "meta/mgdata_generate.json").exists():  # the dataset is open, the attempt under way
        assert job.poll() is None, job.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.2)
    time.sleep(2.0)
    assert job.poll() is None, "the shard finished before it could be killed"
    os.killpg(job.pid, signal.SIGKILL)
    job.communicate()
    again = subprocess.run([*common, "--shard", "1/2", "--out", str(s1)], capture_output=True, text=True,
                           timeout=1800, env=ENV)
    assert again.returncode == 0, again.stdout + again.stderr
    merged = subprocess.run([MGDATA, "merge", str(s0), str(s1), "--out", str(tmp_path / "merged")],
                            capture_output=True, text=True, timeout=1800, env=ENV)
    assert merged.returncode == 0, merged.stdout + merged.stderr
    one = subprocess.run([*common[:-2], "--workers", "1", "--out", str(tmp_path / "one")],
                         capture_output=True, text=True, timeout=1800, env=ENV)
    assert one.returncode == 0, one.stdout + one.stderr
    assert dataset_files(tmp_path / "merged") == dataset_files(tmp_path / "one")
