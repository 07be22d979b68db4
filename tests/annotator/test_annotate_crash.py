"""A SIGKILL while the annotator saves leaves a valid grasp file holding every save that returned.

A child process saves annotated grasps in a loop through the app's writer (:class:`GraspStore`, the
project's atomic writer underneath) into a copy of the real 188 KB ``grasps/jar.json``, printing the count
after each save returns; the test kills it with SIGKILL at a random moment and reads the file back with the
grasp DB's own validating loader. In half of the trials the kill lands inside a write for certain: the
child announces ``W`` from inside the writer once the new file's bytes are synced to its temporary, and
lingers there 50 ms before the rename; those kills must leave the old file (the in-flight save is lost, a
temporary stays behind until the next session removes it).
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from mgdata.annotator.store import GraspStore
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir

KEY = "jar/hinged_05"
CHILD = f"""
import os, sys, time
from pathlib import Path
from mgdata.annotator.store import GraspStore
real_fsync = os.fsync
def announcing_fsync(fd):
    real_fsync(fd)
    print("W", flush=True)
    time.sleep(0.05)
os.fsync = announcing_fsync
store = GraspStore(Path(sys.argv[1]))
for i in range(100000):
    store.add({KEY!r}, (0.01 * (i % 7), 0.0, 0.05), (0.0, 1.0, 0.0, 0.0), "free")
    print(len(store.annotated({KEY!r})), flush=True)
"""


def test_sigkill_during_save_leaves_a_valid_grasp_file(tmp_path: Path) -> None:
    rng = random.Random(13)
    for trial in range(10):
        folder = tmp_path / f"trial_{trial}"
        folder.mkdir()
        shutil.copy(grasps_dir() / "jar.json", folder / "jar.json")
        before = GraspDB.load_dir(folder)
        proc = subprocess.Popen([sys.executable, "-c", CHILD, str(folder)], stdout=subprocess.PIPE, text=True,
                                env={**os.environ, "LP_NUM_THREADS": "1"})
        assert proc.stdout is not None
        target, in_write = rng.randint(2, 8), trial % 2 == 0
        done = 0
        while True:
            line = proc.stdout.readline().strip()
            assert line, f"trial {trial}: the saving process ended early (exit {proc.poll()})"
            if line != "W":
                done = int(line)
            elif done >= target and in_write:
                break  # the child is inside the write: bytes in the temporary, not yet renamed
            if done >= target and not in_write:
                time.sleep(rng.uniform(0.0, 0.05))  # anywhere in a later save
                break
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        rest = [x for x in proc.stdout.read().split() if x != "W"]
        done = int(rest[-1]) if rest else done
        after = GraspDB.load_dir(folder)  # raises GraspDBError on a torn or invalid file
        saved = [g for g in after.grasps(KEY) if g.source == "annotated"]
        assert done <= len(saved) <= done + 1, f"trial {trial}: {done} saves returned, file has {len(saved)}"
        if in_write:
            assert len(saved) == done, f"trial {trial}: a save killed before its rename showed up"
            assert any(p.name.endswith(".tmp") for p in folder.iterdir()), "the kill landed inside a write"
        for key in before.keys:  # every other object's grasps are untouched
            if key != KEY:
                assert after.grasps(key) == before.grasps(key)
        GraspStore(folder)  # a new session removes the temporary a killed write may have left
        assert sorted(p.name for p in folder.iterdir()) == ["jar.json"]
