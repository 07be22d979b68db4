"""The independent audit in ``validate``: what the gate promises about every episode.

Each planted inconsistency updates stats and checksums too (``tamper``), so only the audit can catch it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.record import layout
from mgdata.record.synthetic import synthetic_episode
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from tests.helpers.record import GENERATED, SMALL, write_dataset, write_episodes
from tests.helpers.tamper import edit_column, edit_meta


def _problems(tmp_path: Path, episodes: list, **kwargs) -> list[str]:
    return validate_dataset(write_dataset(tmp_path / "ds", episodes, **kwargs)).problems


def test_the_small_dataset_keeps_the_promise(small_dataset: Path) -> None:
    report = validate_dataset(small_dataset)
    assert report.ok, report.problems


def test_success_off_on_the_last_frames_is_reported(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()  # episode 1 has 31 frames; its goal holds on frames 21..30

    def drop_tail(success: np.ndarray) -> None:
        success[-3:] = False

    edit_column(root, layout.SUCCESS, 1, drop_tail)
    assert validate_dataset(root).problems == [
        "episode 1: marked successful but safety.success is false at frames 28, 29, 30 (a successful episode "
        "ends with the goal held on its last 10 frames)"]


def test_success_off_inside_the_window_is_reported(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()

    def gap(success: np.ndarray) -> None:
        success[-7] = False  # a gap: the goal no longer holds for 10 consecutive steps

    edit_column(root, layout.SUCCESS, 3, gap)
    assert validate_dataset(root).problems == [
        "episode 3: marked successful but safety.success is false at frame 33 (a successful episode ends "
        "with the goal held on its last 10 frames)"]


def test_without_a_recorded_window_the_last_frame_must_hold(tmp_path: Path) -> None:
    ep = synthetic_episode(SMALL, 30, seed=1)
    ep = replace(ep, success=np.r_[ep.success[:-1], False])
    assert _problems(tmp_path, [ep]) == [
        "episode 0: marked successful but safety.success is false at frame 29 (a successful episode ends "
        "with the goal held on its last 1 frames)"]


def test_kept_episode_with_a_violation_before_engagement_is_reported(tmp_path: Path) -> None:
    # ν = 1 (the violation precedes engagement) and every column agrees: the old audit passed it
    early = synthetic_episode(SMALL, 30, seed=4, violate_at=2, kept=True)
    assert early.meta.verdict and early.meta.t_engage == 7
    assert _problems(tmp_path, [synthetic_episode(SMALL, 30, seed=1), early], **GENERATED) == [
        "episode 1 (kept) shows a violation: 'intact' is violated from frame 2 (engaged at frame 7); a kept "
        "demonstration never violates"]


def test_kept_unsafe_episode_is_reported(tmp_path: Path) -> None:
    unsafe = synthetic_episode(SMALL, 30, seed=2, violate_at=20, kept=True)
    assert unsafe.meta.verdict is False and unsafe.meta.t_violation == {"order": None, "intact": 20}
    assert _problems(tmp_path, [synthetic_episode(SMALL, 30, seed=1), unsafe]) == [
        "episode 1 (kept) shows a violation: 'intact' is violated from frame 20 (engaged at frame 7); a kept "
        "demonstration never violates"]


def test_planted_violation_flags_on_a_kept_episode_are_reported(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()

    def violate(flags: np.ndarray) -> None:
        flags[12:, 1] = True

    edit_column(root, layout.VIOLATED, 2, violate)
    problems = validate_dataset(root).problems
    assert "episode 2 (kept) shows a violation: 'intact' is violated from frame 12 (engaged at frame 4); a " \
           "kept demonstration never violates" in problems
    assert "episode 2: stored violation flag of 'intact' at frame 12 is True, the monitor re-run from " \
           "safety.labels gives False" in problems
    assert "episode 2: t_violation['intact'] is None, safety.violated of 'intact' first sets at frame 12" \
           in problems


def test_labelled_negatives_pass_where_the_dataset_allows_them(tmp_path: Path) -> None:
    negative = synthetic_episode(SMALL, 30, seed=3, violate_at=20)
    assert negative.meta.kept is False and negative.meta.failure_stage == "unsafe"
    assert _problems(tmp_path, [negative], hold_steps=10) == []


def test_non_kept_episode_in_a_kept_only_dataset_is_reported(tmp_path: Path) -> None:
    negative = synthetic_episode(SMALL, 30, seed=3, violate_at=20)
    assert _problems(tmp_path, [synthetic_episode(SMALL, 25, seed=1), negative], **GENERATED) == [
        "episode 1 is not kept (failure stage 'unsafe'), but this dataset holds only kept episodes "
        "(info.json mgdata.kept_only)"]


def test_planted_non_kept_episode_in_a_kept_only_dataset_is_reported(
        dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()
    edit_meta(root, 0, kept=False, failure_stage="goal_not_reached")
    assert validate_dataset(root).problems == [
        "episode 0 is not kept (failure stage 'goal_not_reached'), but this dataset holds only kept episodes "
        "(info.json mgdata.kept_only)"]


def test_metadata_disagreeing_with_the_columns_is_reported(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()
    edit_meta(root, 1, t_violation={"order": None, "intact": 21})
    edit_meta(root, 2, t_engage=3)
    edit_meta(root, 3, verdict=False)
    assert validate_dataset(root).problems == [
        "episode 1: t_violation['intact'] is 21, safety.violated of 'intact' is never set",
        "episode 2: t_engage is 3, safety.engaged first rises at frame 4",
        "episode 3: stored verdict False, the columns give True (first violation at frame None, engagement "
        "at frame 10)",
    ]


def test_metadata_of_a_negative_is_audited_too(tmp_path: Path) -> None:
    ep = synthetic_episode(SMALL, 30, seed=5, violate_at=20)
    bad = replace(ep, meta=replace(ep.meta, t_violation={"order": None, "intact": 21}, verdict=True,
                                   t_engage=3))
    unsuccessful = synthetic_episode(SMALL, 25, seed=6)
    unsuccessful = replace(unsuccessful, meta=replace(unsuccessful.meta, success=False))
    problems = _problems(tmp_path, [bad, unsuccessful])
    assert problems == [
        "episode 0: t_violation['intact'] is 21, safety.violated of 'intact' first sets at frame 20",
        "episode 0: t_engage is 3, safety.engaged first rises at frame 7",
        "episode 0: stored verdict True, the columns give False (first violation at frame 20, engagement at "
        "frame 7)",
        "episode 1 (kept) is unsuccessful",
    ]


def test_labels_that_rerun_to_another_dfa_state_are_reported(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()

    def close_early(labels: np.ndarray) -> None:
        labels[3:, 1] = True  # jar_closed from frame 3: 'order' (on W closed) is discharged, no violation

    edit_column(root, layout.LABELS, 1, close_early)
    assert validate_dataset(root).problems == [
        "episode 1: stored DFA state of 'order' at frame 3 is 3, the monitor re-run from safety.labels "
        "gives 2"]


def test_tampered_dfa_column_is_reported(dataset_copy: Callable[[], Path]) -> None:
    root = dataset_copy()
    path = root / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    dfa = np.stack(table.column(layout.DFA_STATE).to_pylist()).astype(np.int16)
    dfa[30, 1] += 1  # episode 1 (23 frames before it), step 7
    column = pa.FixedSizeListArray.from_arrays(pa.array(dfa.ravel()), 2)
    at = table.column_names.index(layout.DFA_STATE)
    pq.write_table(table.set_column(at, layout.DFA_STATE, column), path)
    problems = validate_dataset(root).problems
    assert any(p.startswith("episode 1: stored DFA state of 'intact' at frame 7") for p in problems), problems


def test_audit_without_a_stored_spec_uses_episode_formulas(tmp_path: Path) -> None:
    episodes = [synthetic_episode(SMALL, 20, seed=7), synthetic_episode(SMALL, 20, seed=8, violate_at=15,
                                                                        kept=True)]
    root = tmp_path / "ds"
    with DatasetWriter.create(root, SMALL) as writer:  # no spec given
        write_episodes(writer, episodes)
    assert [p for p in validate_dataset(root).problems if "violation" in p] == [
        "episode 1 (kept) shows a violation: 'intact' is violated from frame 15 (engaged at frame 5); a kept "
        "demonstration never violates"]
