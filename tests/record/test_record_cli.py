"""``mgdata info`` and ``mgdata export`` from the command line, and the summary behind ``info``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from mgdata.record.summary import summarize
from tests.helpers.record import LENGTHS

MGDATA = [sys.executable, "-c", "from mgdata.cli import main; main()"]


def test_summary_counts(small_dataset: Path) -> None:
    s = summarize(small_dataset)
    assert (s.episodes, s.frames, s.fps, s.tasks) == (len(LENGTHS), sum(LENGTHS), 20, len(LENGTHS))
    assert s.by_family == {"jar": 4} and s.by_condition == {"base": 3, "ood_lighting": 1}
    assert (s.kept, s.negatives, s.unsafe, s.attempts) == (4, 0, 0, None)
    assert s.draws == 1 + 2 + 3 + 4  # synthetic task ids 3, 4, 5, 6 with draws 0..3
    assert s.size_bytes > 10_000 and abs(s.duration_s - sum(LENGTHS) / 20) < 1e-9


def test_info_and_export_commands(small_dataset: Path, tmp_path: Path) -> None:
    text = subprocess.run([*MGDATA, "info", str(small_dataset)], capture_output=True, text=True, timeout=120)
    assert text.returncode == 0, text.stderr
    assert "episodes    4 (4 kept, 0 labelled negatives, 0 unsafe)" in text.stdout
    assert "cameras     front, wrist, left (h264)" in text.stdout
    as_json = subprocess.run([*MGDATA, "info", "--json", str(small_dataset)], capture_output=True, text=True,
                             timeout=120)
    assert json.loads(as_json.stdout)["frames"] == sum(LENGTHS)
    out = tmp_path / "groot"
    done = subprocess.run([*MGDATA, "export", str(small_dataset), str(out), "--format", "groot",
                           "--cameras", "front,wrist"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and (out / "meta/modality.json").exists()
    again = subprocess.run([*MGDATA, "export", str(small_dataset), str(out), "--format", "groot"],
                           capture_output=True, text=True, timeout=120)
    assert again.returncode == 2 and "already exists" in again.stderr and "Traceback" not in again.stderr
