"""The independent safety audit in ``validate``: replays the monitor on stored labels."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from conftest import SMALL, write_dataset, write_episodes

from mgdata.record import layout
from mgdata.record.synthetic import synthetic_episode
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter


def _problems(tmp_path: Path, episodes: list, **kwargs) -> list[str]:
    return validate_dataset(write_dataset(tmp_path / "ds", episodes, **kwargs)).problems


def test_kept_unsafe_episode_is_reported(tmp_path: Path) -> None:
    safe = synthetic_episode(SMALL, 30, seed=1)
    unsafe = synthetic_episode(SMALL, 30, seed=2, violate_at=20, kept=True)
    assert unsafe.meta.verdict is False and unsafe.meta.t_violation == {"order": None, "intact": 20}
    problems = _problems(tmp_path, [safe, unsafe])
    assert problems == ["episode 1 (kept) is unsafe: 'intact' violated at step 20, engaged at step 7"]


def test_labelled_negatives_and_pre_engagement_violations_pass(tmp_path: Path) -> None:
    negative = synthetic_episode(SMALL, 30, seed=3, violate_at=20)  # kept=False: a labelled negative
    early = synthetic_episode(SMALL, 30, seed=4, violate_at=2)      # violated before engagement: ν = 1
    assert negative.meta.kept is False and early.meta.verdict and early.meta.kept
    assert _problems(tmp_path, [negative, early]) == []


def test_inconsistent_metadata_is_reported(tmp_path: Path) -> None:
    ep = synthetic_episode(SMALL, 30, seed=5, violate_at=20, kept=False)
    bad = replace(ep, meta=replace(ep.meta, t_violation={"order": None, "intact": 21}, verdict=True,
                                   t_engage=3))
    unsuccessful = synthetic_episode(SMALL, 25, seed=6)
    unsuccessful = replace(unsuccessful, meta=replace(unsuccessful.meta, success=False))
    problems = _problems(tmp_path, [bad, unsuccessful])
    assert "episode 0: t_violation['intact'] is 21, the replay gives 20" in problems
    assert "episode 0: t_engage is 3, the engaged flag first rises at 7" in problems
    assert "episode 0: stored verdict True, the replay gives False" in problems
    assert "episode 1 (kept) is unsuccessful" in problems


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
    assert any(p.startswith("episode 1: stored DFA state of 'intact' at step 7") for p in problems), problems


def test_audit_without_a_stored_spec_uses_episode_formulas(tmp_path: Path) -> None:
    episodes = [synthetic_episode(SMALL, 20, seed=7), synthetic_episode(SMALL, 20, seed=8, violate_at=15,
                                                                        kept=True)]
    root = tmp_path / "ds"
    with DatasetWriter.create(root, SMALL) as writer:  # no spec given
        write_episodes(writer, episodes)
    assert [p for p in validate_dataset(root).problems if "unsafe" in p] == [
        "episode 1 (kept) is unsafe: 'intact' violated at step 15, engaged at step 5"]
