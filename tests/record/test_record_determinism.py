"""Same frames → same bytes: two writes, and episodes staged by parallel workers then appended in order."""

from __future__ import annotations

import dataclasses
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from mgdata.errors import DatasetError
from mgdata.record.staging import EpisodeStager
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode
from mgdata.record.writer import DatasetWriter
from tests.helpers.record import GENERATED, SMALL, small_episodes, tree_digest, write_dataset


def test_two_writes_give_identical_bytes(small_dataset: Path, tmp_path: Path) -> None:
    again = write_dataset(tmp_path / "again", small_episodes(), **GENERATED)
    assert tree_digest(again) == tree_digest(small_dataset)


def _stage(job: tuple[Path, int, int, int]) -> Path:
    """Worker: record one episode into its own staged folder (the dataset is never touched)."""
    folder, length, seed, draw = job
    ep = synthetic_episode(SMALL, length, seed=seed, draw_index=draw)
    stager = EpisodeStager(folder, SMALL)
    for frame in ep.frames():
        stager.add_frame(frame)
    stager.end_episode(ep.meta)
    return folder


def test_parallel_staging_matches_single_process(small_dataset: Path, tmp_path: Path) -> None:
    reference = small_episodes()
    jobs = [(tmp_path / "stage" / f"draw-{i:06d}", ep.length, ep.seed, i) for i, ep in enumerate(reference)]
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        staged = list(pool.map(_stage, reversed(jobs)))  # finished out of order on purpose
    root = tmp_path / "parallel"
    with DatasetWriter.create(root, SMALL, spec=SYNTHETIC_SPEC, **GENERATED) as writer:
        for folder in sorted(staged):
            writer.append_staged(folder)
    assert not any((tmp_path / "stage").iterdir())  # appended folders are consumed
    assert tree_digest(root) == tree_digest(small_dataset)


def test_staged_episode_must_match_the_dataset(tmp_path: Path) -> None:
    other = synthetic_episode(dataclasses.replace(SMALL, image_width=32, image_height=32), 5, 1)
    stager = EpisodeStager(tmp_path / "odd", other.schema)
    for frame in other.frames():
        stager.add_frame(frame)
    stager.end_episode(other.meta)
    with DatasetWriter.create(tmp_path / "ds", SMALL) as writer:
        try:
            writer.append_staged(tmp_path / "odd")
        except DatasetError as err:
            assert "staged with schema" in str(err)
        else:
            raise AssertionError("a staged episode of another schema was appended")
        assert writer.num_episodes == 0
