"""Every family present: its base scenario restores, a kept demo of its task 0 replays bit for bit with
SSR 100 %, and hold is vacuous-safe (slow: one planned demo per family)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task, cached_grasp_db
from mgdata.evaluate.policies import HoldPolicy, ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings, RolloutJob, rollout
from mgdata.paths import grasps_dir
from mgdata.record.reader import DatasetReader
from mgdata.record.recorder import schema_for
from mgdata.record.writer import DatasetWriter
from mgdata.scenarios.store import build_scenario, write_manifest
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import family_recipes

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("family", family_recipes())
def test_reference_policies_on_every_family(family: str, tmp_path: Path, serving) -> None:  # type: ignore[no-untyped-def]
    recipe = load_family_recipe(family)
    scenarios = tmp_path / "scenarios"
    build_scenario(recipe, 0, "base", scenarios)
    write_manifest(scenarios)
    ex = Executor(base_task(recipe, 0), recipe, grasps=cached_grasp_db(grasps_dir()), render=False)
    schema = dataclasses.replace(schema_for(ex.scene, recipe.spec, None), image_height=0, image_width=0)
    with DatasetWriter.create(tmp_path / "demo", schema, spec=recipe.spec,
                              hold_steps=recipe.tasks.hold_steps) as writer:
        kept = next((draw for draw in range(6) if ex.run(draw, writer).kept), None)
    ex.close()
    assert kept is not None, f"no kept {family} demo of task 0 in 6 draws"
    ep = DatasetReader(tmp_path / "demo").episode(0)
    scenario = f"{family}/task_0000/base"
    replay = rollout(RolloutJob(scenarios, scenario, 0),
                     LoopSettings(serving(ReplayPolicy(tmp_path / "demo", chunk=16, scenarios=scenarios))))
    rec = replay.record
    assert rec["success"] and rec["t_violation"] is None and rec["steps"] <= ep.length - 1
    states = np.stack([f.physics_state for f in replay.frames])
    assert states.tobytes() == ep.physics_state[: len(states)].tobytes()
    hold = rollout(RolloutJob(scenarios, scenario, 0), LoopSettings(serving(HoldPolicy(16)), horizon=100))
    assert not hold.record["engaged"] and hold.record["t_violation"] is None and not hold.record["success"]
