"""``mgdata tasks F``: the gate report a user reads before generating, and its contact sheet."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2

MGDATA = [str(Path(sys.executable).parent / "mgdata")]


def _tasks(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*MGDATA, "tasks", *args], capture_output=True, text=True, timeout=600)


def test_lists_the_gated_tasks_and_draws_one_row_per_task(tmp_path: Path) -> None:
    sheet = tmp_path / "jar_tasks.png"
    proc = _tasks("jar", "--tasks", "0-1", "--render", "--out", str(sheet))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    assert "task 0 (draw " in out and "task 1 (draw " in out and "reachable grasps" in out
    assert "objects: jar=jar/hinged_" in out and "prompt: Close the lid of the hinged jar" in out
    assert out.rstrip().endswith("2 of 2 tasks pass the initial-state gate")
    image = cv2.imread(str(sheet))
    assert image is not None and image.shape[0] == 2 * 192 and image.shape[1] == 2 * 192  # 2 rows × 2 cameras


def test_bad_input_is_one_error_line(tmp_path: Path) -> None:
    for args, message in ((("nosuch",), "no recipe for family 'nosuch'"),
                          (("jar", "--tasks", "99"), "jar has tasks 0 … 25, not 99"),
                          (("jar", "--render", "--out", str(tmp_path / "no" / "x.png")), "existing folder")):
        proc = _tasks(*args)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1 and message in lines[0], (args, proc.stderr)
        assert not (tmp_path / "no").exists()
