"""Bad input: one clear error naming the file (reader) or one line per problem (validator), no traceback."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.episode import Frame
from mgdata.record.reader import DatasetReader
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from tests.helpers.record import SMALL, small_episodes

DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"
VIDEO = "videos/observation.images.wrist/chunk-000/file-000.mp4"


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _garbage(path: Path) -> None:
    path.write_bytes(b"not a real file " * 64)


def _edit_info(change: Callable[[dict], None]) -> Callable[[Path], None]:
    def apply(root: Path) -> None:
        info = json.loads((root / layout.INFO_PATH).read_text())
        change(info)
        (root / layout.INFO_PATH).write_text(json.dumps(info))
    return apply


# (case, damage, file named by the reader's error or None if the reader opens it fine)
CASES = [
    ("truncated data parquet", lambda r: _truncate(r / DATA), DATA),
    ("garbage episodes parquet", lambda r: _garbage(r / EPISODES), EPISODES),
    ("truncated mp4", lambda r: _truncate(r / VIDEO), VIDEO),
    ("garbage mp4", lambda r: _garbage(r / VIDEO), VIDEO),
    ("missing info.json", lambda r: (r / layout.INFO_PATH).unlink(), layout.INFO_PATH),
    ("missing tasks", lambda r: (r / layout.TASKS_PATH).unlink(), layout.TASKS_PATH),
    ("missing stats", lambda r: (r / layout.STATS_PATH).unlink(), layout.STATS_PATH),
    ("missing video", lambda r: (r / VIDEO).unlink(), VIDEO),
    ("other codebase version", _edit_info(lambda i: i.update(codebase_version="v2.1")), layout.INFO_PATH),
    ("not written by mgdata", _edit_info(lambda i: i.pop("mgdata")), layout.INFO_PATH),
    ("info.json not JSON", lambda r: (r / layout.INFO_PATH).write_text("{oops"), layout.INFO_PATH),
    ("stored spec invalid", _edit_info(lambda i: i["mgdata"]["spec"]["propositions"]["jar_closed"].update(
        evaluator="ajar")), layout.INFO_PATH),
]


@pytest.mark.parametrize(("case", "damage", "named"), CASES, ids=[c[0] for c in CASES])
def test_damage_is_reported_naming_the_file(dataset_copy: Callable[[], Path], case: str,
                                            damage: Callable[[Path], None], named: str) -> None:
    root = dataset_copy()
    damage(root)
    with pytest.raises(DatasetError) as err:  # whichever reader call touches the damaged file
        reader = DatasetReader(root)
        assert reader.spec is not None
        reader.stats()
        for i in range(reader.num_episodes):
            reader.episode(i)
            reader.frames(i, "wrist")
    assert named in str(err.value)
    report = validate_dataset(root)
    assert not report.ok and any(named in p for p in report.problems), report.problems


def test_cli_validate_exits_nonzero_without_traceback(dataset_copy: Callable[[], Path],
                                                      small_dataset: Path) -> None:
    root = dataset_copy()
    _truncate(root / DATA)
    run = [sys.executable, "-c", "from mgdata.cli import main; main()", "validate"]
    bad = subprocess.run([*run, str(root)], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 1 and "Traceback" not in bad.stdout + bad.stderr
    assert f"problem: {root / DATA}" in bad.stdout
    good = subprocess.run([*run, str(small_dataset)], capture_output=True, text=True, timeout=120)
    assert good.returncode == 0 and "ok (4 episodes" in good.stdout


def test_stray_data_file_and_tampered_rows_are_problems(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()
    table = pq.read_table(root / DATA)
    pq.write_table(table, root / "data/chunk-000/file-001.parquet")  # LeRobot would load it too
    frame_index = table.column("frame_index").to_numpy().copy()
    frame_index[5] = 99
    pq.write_table(table.set_column(table.column_names.index("frame_index"), "frame_index",
                                    [frame_index]), root / DATA)
    problems = validate_dataset(root).problems
    assert any("file-001.parquet: not referenced" in p for p in problems)
    assert any("episode 0: column 'frame_index'" in p for p in problems)
    assert any("SHA-256" in p for p in problems)


def _frame(**change: object) -> Frame:
    frame = next(small_episodes((3,))[0].frames())
    return replace(frame, **change)


@pytest.mark.parametrize(("change", "message"), [
    ({"state": np.zeros(7, np.float32)}, "observation.state has shape"),
    ({"action": np.full(8, np.nan, np.float32)}, "non-finite"),
    ({"labels": np.zeros(3, bool)}, "safety.labels has shape"),
    ({"dfa_state": np.array([0, 40000])}, "do not fit int16"),
    ({"images": {"front": np.zeros((64, 64, 3), np.uint8)}}, "expected"),
    ({"images": {c: np.zeros((64, 64, 3), np.float32) for c in SMALL.cameras}}, "expected uint8"),
])
def test_writer_rejects_bad_frames(tmp_path: Path, change: dict, message: str) -> None:
    with DatasetWriter.create(tmp_path / "ds", SMALL) as writer:
        with pytest.raises(DatasetError, match=message):
            writer.add_frame(_frame(**change))
        writer.discard_episode()
        assert writer.num_episodes == 0


def test_writer_rejects_bad_metadata_and_misuse(tmp_path: Path, small_dataset: Path) -> None:
    ep = small_episodes((4,))[0]
    with DatasetWriter.create(tmp_path / "ds", SMALL) as writer:
        with pytest.raises(DatasetError, match="without any add_frame"):
            writer.end_episode(ep.meta)
        for frame in ep.frames():
            writer.add_frame(frame)
        with pytest.raises(DatasetError, match="formulas"):
            writer.end_episode(replace(ep.meta, formulas={"other": "G a"}))
        assert writer.num_episodes == 0
    with pytest.raises(DatasetError, match="not empty"):
        DatasetWriter.create(small_dataset, SMALL)
    with pytest.raises(DatasetError, match="differs from the requested"):
        DatasetWriter.open(small_dataset, replace(SMALL, fps=30))
    with pytest.raises(DatasetError, match="no dataset here"):
        DatasetWriter.open(tmp_path / "nothing")
    with DatasetWriter.open(small_dataset), pytest.raises(DatasetError, match="another process"):
        DatasetWriter.open(small_dataset)
