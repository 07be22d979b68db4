"""Temporal ensembling (ACT's scheme) in the evaluation client: the ensembled action is the weighted mean of
every prediction made for a step, oldest first, weights exp(-coeff * k); a replayed demonstration, whose
chunks all agree, is reproduced bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.evaluate.ensemble import ChunkEnsemble
from mgdata.evaluate.policies import ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings, RolloutJob, rollout
from mgdata.record.reader import DatasetReader
from tests.helpers.cli import mgdata_here


def _reference(queries: list[tuple[int, np.ndarray]], step: int, coeff: float) -> np.ndarray:
    """ACT's definition, written out: all predictions for ``step`` in query order, weights exp(-coeff*k)."""
    preds = [chunk[step - t] for t, chunk in queries if t <= step < t + len(chunk)]
    num = sum(np.exp(-coeff * k) * p for k, p in enumerate(preds))
    return num / sum(np.exp(-coeff * k) for k in range(len(preds)))


@settings(max_examples=60, deadline=None)
@given(coeff=st.floats(0.0, 2.0), lengths=st.lists(st.integers(1, 6), min_size=1, max_size=12),
       gaps=st.lists(st.integers(1, 3), min_size=12, max_size=12), seed=st.integers(0, 2**16))
def test_the_ensemble_is_acts_weighted_mean(coeff: float, lengths: list[int], gaps: list[int],
                                            seed: int) -> None:
    rng = np.random.default_rng(seed)
    ensemble, queries, step = ChunkEnsemble(coeff), [], 0
    for length, gap in zip(lengths, gaps, strict=False):
        chunk = rng.normal(size=(length, 8))
        ensemble.add(step, chunk)
        queries.append((step, chunk))
        for t in range(step, step + min(gap, length)):  # actions are read in step order, as a rollout does
            np.testing.assert_allclose(ensemble.action(t), _reference(queries, t, coeff), rtol=1e-12)
        step += min(gap, length)
    with pytest.raises(ValueError, match="no chunk predicts"):
        ensemble.action(step + 100)


def test_a_bad_coefficient_is_refused(tmp_path: Path) -> None:
    for coeff in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="coefficient"):
            ChunkEnsemble(coeff)
        proc = mgdata_here("eval", "--policy", "ws://127.0.0.1:9", "--scenarios", tmp_path / "none",
                           "--ensemble", str(coeff), "--out", tmp_path / "out")
        assert proc.returncode == 2 and proc.stderr.startswith("error: --ensemble:"), proc.stderr
        assert "Traceback" not in proc.stderr and not (tmp_path / "out").exists()


def test_an_ensembled_replay_reproduces_the_demo_bit_for_bit(scenario_set: Path, demo: Path,
                                                             serving) -> None:  # type: ignore[no-untyped-def]
    url = serving(ReplayPolicy(demo, chunk=16, scenarios=scenario_set))
    ep = DatasetReader(demo).episode(0)
    result = rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0), LoopSettings(url, ensemble=0.01))
    assert result.record["success"] and result.record["steps"] == ep.length - 1
    states = np.stack([f.physics_state for f in result.frames])
    assert states.tobytes() == ep.physics_state[: len(states)].tobytes()
