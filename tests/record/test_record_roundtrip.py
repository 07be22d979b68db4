"""Write → read: identical numeric columns and metadata, faithful frames, exact stats, file rollover."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.record import layout
from mgdata.record.reader import DatasetReader
from mgdata.record.stats import image_stats, numeric_stats, rgb_histogram
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from tests.helpers.record import LENGTHS, SMALL, psnr, small_episodes, write_dataset, write_episodes


def test_numeric_columns_and_metadata_round_trip(small_dataset: Path) -> None:
    reader = DatasetReader(small_dataset)
    episodes = small_episodes()
    assert reader.num_episodes == len(LENGTHS) and reader.num_frames == sum(LENGTHS)
    assert reader.schema == SMALL and reader.spec == SYNTHETIC_SPEC
    start = 0
    for i, ep in enumerate(episodes):
        got = reader.episode(i)
        np.testing.assert_array_equal(got.state, ep.state)
        np.testing.assert_array_equal(got.action, ep.action)
        np.testing.assert_array_equal(got.labels, ep.labels)
        np.testing.assert_array_equal(got.dfa_state, ep.dfa_state)
        np.testing.assert_array_equal(got.violated, ep.violated)
        np.testing.assert_array_equal(got.engaged, ep.engaged)
        np.testing.assert_array_equal(got.success, ep.success)
        assert got.meta == ep.meta and got.task == ep.meta.prompt
        assert got.frame_index.tolist() == list(range(ep.length))
        assert got.global_index.tolist() == list(range(start, start + ep.length))
        np.testing.assert_array_equal(got.timestamp, (np.arange(ep.length) / SMALL.fps).astype(np.float32))
        start += ep.length
    assert reader.episode(2).state.dtype == np.float32 and reader.episode(2).dfa_state.dtype == np.int16


def test_frames_decode_close_to_the_recorded_ones(tmp_path: Path) -> None:
    schema = synthetic_schema(cameras=("front", "wrist"), size=256)
    episodes = [synthetic_episode(schema, n, seed=s) for s, n in [(1, 12), (2, 20)]]
    reader = DatasetReader(write_dataset(tmp_path / "ds", episodes))
    for i, ep in enumerate(episodes):
        for cam in schema.cameras:
            frames = reader.frames(i, cam)
            assert frames.shape == (ep.length, 256, 256, 3) and frames.dtype == np.uint8
            worst = min(psnr(frames[t], ep.images(t)[cam]) for t in range(ep.length))
            assert worst >= 30.0, f"episode {i} {cam}: PSNR {worst:.1f} dB"


def test_stats_match_the_data(small_dataset: Path) -> None:
    """Dataset stats are merged episode by episode: count, min, max, mean and std equal numpy's over all
    frames; each quantile is the count-weighted mean of the episodes' exact quantiles; image stats are
    exact (pixel histograms)."""
    episodes = small_episodes()
    stats = json.loads((small_dataset / layout.STATS_PATH).read_text())
    state = np.concatenate([ep.state for ep in episodes])
    for key, value in numeric_stats(state).items():
        if not key.startswith("q"):
            np.testing.assert_allclose(stats[layout.STATE][key], value, rtol=1e-12)
    lengths = np.array([ep.length for ep in episodes], np.float64)
    for key, q in (("q01", 0.01), ("q50", 0.5), ("q99", 0.99)):
        per_episode = np.stack([np.quantile(ep.state.astype(np.float64), q, axis=0) for ep in episodes])
        want = lengths @ per_episode / lengths.sum()
        np.testing.assert_allclose(stats[layout.STATE][key], want, rtol=1e-12)
    labels = np.concatenate([ep.labels for ep in episodes])
    np.testing.assert_allclose(stats[layout.LABELS]["mean"], labels.mean(axis=0))
    index = np.arange(sum(LENGTHS))
    assert stats["index"]["max"] == [index.max()] and stats["index"]["count"] == [len(index)]
    for cam in SMALL.cameras:
        hist = sum(rgb_histogram(ep.images(t)[cam]) for ep in episodes for t in range(ep.length))
        for key, value in image_stats(hist, sum(LENGTHS)).items():
            np.testing.assert_allclose(stats[layout.video_key(cam)][key], value, rtol=1e-12)
    reader = DatasetReader(small_dataset)
    np.testing.assert_allclose(reader.record(1).stats[layout.ACTION]["std"], episodes[1].action.std(axis=0),
                               rtol=1e-6)


def test_layout_matches_lerobot_v30(small_dataset: Path) -> None:
    info = json.loads((small_dataset / layout.INFO_PATH).read_text())
    assert info["codebase_version"] == "v3.0" and info["total_tasks"] == len(LENGTHS)
    assert info["splits"] == {"train": f"0:{len(LENGTHS)}"}
    assert info["features"]["observation.images.front"]["info"]["video.codec"] == "h264"
    assert info["features"]["safety.dfa_state"]["names"] == ["order", "intact"]
    data = pq.read_table(small_dataset / "data/chunk-000/file-000.parquet")
    assert data.schema.field("observation.state").type == pa.list_(pa.float32(), 8)
    assert data.schema.field("safety.engaged").type == pa.bool_()
    episodes = pq.read_table(small_dataset / "meta/episodes/chunk-000/file-000.parquet")
    assert episodes.column("dataset_to_index").to_pylist()[-1] == sum(LENGTHS)
    assert episodes.column("videos/observation.images.wrist/from_timestamp").to_pylist()[1] == LENGTHS[0] / 20
    assert episodes.column("mgdata/family").to_pylist() == ["jar"] * len(LENGTHS)
    tasks = pq.read_table(small_dataset / layout.TASKS_PATH)
    assert b"pandas" in tasks.schema.metadata and tasks.column("task_index").to_pylist() == [0, 1, 2, 3]
    assert not (small_dataset / layout.WORK_DIR).exists()


def test_files_roll_over_by_size_duration_and_chunk(tmp_path: Path) -> None:
    episodes = small_episodes()
    root = write_dataset(tmp_path / "ds", episodes, data_file_mb=0, video_file_seconds=2.0, chunks_size=2)
    data = sorted(p.relative_to(root).as_posix() for p in (root / "data").rglob("*.parquet"))
    assert data == ["data/chunk-000/file-000.parquet", "data/chunk-000/file-001.parquet",
                    "data/chunk-001/file-000.parquet", "data/chunk-001/file-001.parquet"]
    # 40 frames per video file at most: 23 | 31 | 17 | 40 each start a new file
    videos = sorted(p.relative_to(root / "videos").as_posix() for p in (root / "videos").rglob("*.mp4"))
    assert len(videos) == 4 * len(SMALL.cameras)
    assert "observation.images.left/chunk-001/file-001.mp4" in videos
    reader = DatasetReader(root)
    for i, ep in enumerate(episodes):
        np.testing.assert_array_equal(reader.episode(i).state, ep.state)
        assert reader.frames(i, "wrist").shape[0] == ep.length
    assert validate_dataset(root).ok


def test_resume_continues_appending(tmp_path: Path) -> None:
    episodes = small_episodes()
    root = write_dataset(tmp_path / "ds", episodes[:2])
    with DatasetWriter.open(root, SMALL) as writer:
        assert writer.num_episodes == 2 and [m.draw_index for m in writer.episodes_meta()] == [0, 1]
        write_episodes(writer, episodes[2:])
        writer.record_attempts(7)
    reader = DatasetReader(root)
    assert reader.num_episodes == 4 and reader.info["mgdata"]["attempts"] == 7
    np.testing.assert_array_equal(reader.episode(3).labels, episodes[3].labels)
    assert validate_dataset(root).ok


def test_av1_datasets_append_and_validate(tmp_path: Path) -> None:
    episodes = small_episodes((12, 9))
    root = write_dataset(tmp_path / "av1", episodes, codec="av1")
    reader = DatasetReader(root)
    assert reader.video.codec == "av1" and reader.info["features"]["observation.images.left"]["info"][
        "video.codec"] == "av1"
    assert reader.frames(1, "left").shape == (9, 64, 64, 3)
    assert validate_dataset(root, decode_all=True).ok


def test_a_dataset_written_before_the_penetration_columns_still_reads(tmp_path: Path) -> None:
    """Episodes tables without ``mgdata/max_penetration``, ``penetration_step`` and ``penetration_bodies``
    (datasets older than the figure) read with all three ``None``."""
    root = write_dataset(tmp_path / "old", small_episodes((12, 9)), hold_steps=5)
    dropped = ("mgdata/max_penetration", "mgdata/penetration_step", "mgdata/penetration_bodies")
    for path in (root / layout.EPISODES_DIR).rglob("*.parquet"):
        table = pq.read_table(path)
        assert all(name in table.column_names for name in dropped)
        pq.write_table(table.drop_columns(list(dropped)), path)
    metas = [r.meta for r in DatasetReader(root).records()]
    assert len(metas) == 2
    assert all(m.max_penetration is None and m.penetration_step is None and m.penetration_bodies is None
               for m in metas)
