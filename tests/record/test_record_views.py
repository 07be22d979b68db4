"""Loader views and exports: camera subsets and keys per model convention, packets copied bit-exactly."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from mgdata.errors import DatasetError
from mgdata.record.export import export_dataset
from mgdata.record.reader import DatasetReader
from mgdata.record.validate import validate_dataset
from mgdata.record.video import decode
from tests.helpers.record import LENGTHS, small_episodes


def _jsonl(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_smolvla_view_is_a_valid_v30_dataset(small_dataset: Path, tmp_path: Path) -> None:
    out = export_dataset(small_dataset, tmp_path / "smol", "smolvla", overview="left")
    report = validate_dataset(out)
    assert report.ok, report.problems
    src, view = DatasetReader(small_dataset), DatasetReader(out)
    assert view.schema.cameras == ("top", "wrist")
    assert sorted(k for k, f in view.info["features"].items() if f["dtype"] == "video") == [
        "observation.images.top", "observation.images.wrist"]
    for i in range(src.num_episodes):
        np.testing.assert_array_equal(view.frames(i, "top"), src.frames(i, "left"))
        np.testing.assert_array_equal(view.episode(i).labels, src.episode(i).labels)
        assert view.episode(i).meta == src.episode(i).meta


def test_v21_export_layout_and_content(small_dataset: Path, tmp_path: Path) -> None:
    out = export_dataset(small_dataset, tmp_path / "v21", "v2.1")
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v2.1" and info["total_videos"] == 3 * len(LENGTHS)
    assert info["total_chunks"] == 1 and info["data_path"].endswith("episode_{episode_index:06d}.parquet")
    assert [e["length"] for e in _jsonl(out / "meta/episodes.jsonl")] == list(LENGTHS)
    assert [t["task_index"] for t in _jsonl(out / "meta/tasks.jsonl")] == [0, 1, 2, 3]
    stats = _jsonl(out / "meta/episodes_stats.jsonl")
    assert stats[2]["stats"]["observation.images.front"]["count"] == [LENGTHS[2]]
    assert _jsonl(out / "meta/mgdata_episodes.jsonl")[1]["seed"] == 11
    src = DatasetReader(small_dataset)
    for i, ep in enumerate(small_episodes()):
        rows = pq.read_table(out / f"data/chunk-000/episode_{i:06d}.parquet")
        rec = src.record(i)
        assert rows.column("index").to_pylist() == list(range(rec.from_index, rec.to_index))
        np.testing.assert_array_equal(np.stack(rows.column("observation.state").to_pylist()), ep.state)
        video = out / f"videos/chunk-000/observation.images.wrist/episode_{i:06d}.mp4"
        np.testing.assert_array_equal(decode(video, 0, ep.length, 20), src.frames(i, "wrist"))


def test_pi0_and_groot_conventions(small_dataset: Path, tmp_path: Path) -> None:
    pi0 = export_dataset(small_dataset, tmp_path / "pi0", "pi0")
    feats = json.loads((pi0 / "meta/info.json").read_text())["features"]
    assert {"image", "wrist_image", "state", "actions", "safety.violated"} <= set(feats)
    assert "observation.state" not in feats and feats["image"]["dtype"] == "video"
    columns = pq.read_table(pi0 / "data/chunk-000/episode_000000.parquet").column_names
    assert columns[:2] == ["state", "actions"]
    assert (pi0 / "videos/chunk-000/image/episode_000003.mp4").exists()
    groot = export_dataset(small_dataset, tmp_path / "groot", "groot", cameras=("front", "wrist"))
    modality = json.loads((groot / "meta/modality.json").read_text())
    assert modality["state"] == {"single_arm": {"start": 0, "end": 7}, "gripper": {"start": 7, "end": 8}}
    assert modality["video"] == {"front": {"original_key": "observation.images.front"},
                                 "wrist": {"original_key": "observation.images.wrist"}}
    assert modality["annotation"]["human.task_description"]["original_key"] == "task_index"
    assert not (groot / "videos/chunk-000/observation.images.left").exists()


def test_export_errors(small_dataset: Path, tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="unknown"):
        export_dataset(small_dataset, tmp_path / "a", "openvla")
    with pytest.raises(DatasetError, match="not a camera"):
        export_dataset(small_dataset, tmp_path / "b", "smolvla", overview="top")
    with pytest.raises(DatasetError, match="already exists"):
        export_dataset(small_dataset, small_dataset, "v2.1")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b.partial").exists()
