"""Demonstrations in the scenario conditions (`mgdata generate --condition`) and single-factor
attribution from a kept demonstration: its recorded actions, replayed open loop in the target and
environment variants of its task, give the same physics trajectory bit for bit (raw MuJoCo states)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.errors import DatasetError, RecipeError
from mgdata.generate.run import GenerateJob, generate
from mgdata.record.physics import model_bytes, physics_state
from mgdata.record.reader import DatasetReader
from mgdata.scenarios.conditions import attempt_condition, variant
from mgdata.sim.controller import JointController
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.variants import CONDITIONS


def test_all_cycles_through_the_five_conditions_by_draw() -> None:
    assert [attempt_condition("all", d) for d in range(7)] == [*CONDITIONS, *CONDITIONS[:2]]
    assert {attempt_condition("location", d) for d in range(5)} == {"location"}
    with pytest.raises(RecipeError, match="--condition 'lighting'"):
        attempt_condition("lighting", 0)


@pytest.fixture(scope="module")
def cycled(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Jar task 0, ``--condition all``: draw 0 runs in ``base``, draw 1 in ``target`` (both recorded)."""
    out = tmp_path_factory.mktemp("cycled") / "jar"
    summary = generate(GenerateJob(family="jar", n=2, out=out, tasks=(0,), workers=1, keep_failed=True,
                                   max_attempts=2, condition="all"))
    assert summary.stopped != "interrupted"
    return out


def _episodes(out: Path) -> dict[int, tuple[DatasetReader, int]]:
    """draw index -> (reader, episode) over the kept and the failed dataset."""
    found = {}
    for root in (out, out.with_name(out.name + "_failed")):
        if root.is_dir():
            reader = DatasetReader(root)
            for i in range(reader.num_episodes):
                found[reader.record(i).meta.draw_index] = (reader, i)
    return found


def test_generate_runs_each_draw_in_its_condition_and_records_it(cycled: Path) -> None:
    recipe = load_family_recipe("jar")
    base = base_task(recipe, 0)
    episodes = _episodes(cycled)
    assert sorted(episodes) == [0, 1]
    for draw, condition in ((0, "base"), (1, "target")):
        reader, i = episodes[draw]
        meta = reader.record(i).meta
        task = base if condition == "base" else variant(recipe, base, condition)[0]
        assert meta.condition == condition and meta.prompt == task.prompt
        # the episode ran in exactly the scene the scenario builder makes for this condition
        assert reader.scene_mjb(i) == model_bytes(build_scene(task).model), condition
    target = build_scene(variant(recipe, base, "target")[0]).model
    assert not np.array_equal(target.geom_rgba, build_scene(base).model.geom_rgba)
    # a dataset of one condition is not resumed with another
    with pytest.raises(DatasetError, match="inputs_digest"):
        generate(GenerateJob(family="jar", n=3, out=cycled, tasks=(0,), workers=1, condition="base"))


def test_a_kept_base_demo_replays_bit_identically_in_target_and_environment(cycled: Path) -> None:
    reader, i = _episodes(cycled)[0]
    assert reader.record(i).meta.kept and reader.root == cycled
    episode = reader.episode(i)
    recorded = episode.physics_state
    assert recorded is not None and len(recorded) > 100
    recipe = load_family_recipe("jar")
    base = base_task(recipe, 0)
    for condition in ("base", "target", "environment"):
        task = base if condition == "base" else variant(recipe, base, condition)[0]
        scene = build_scene(task)
        ctl = JointController(scene)
        states = [physics_state(scene.model, scene.data)]
        for action in episode.action[:-1]:  # open loop from the variant's own initial state
            ctl.apply(action)
            ctl.step()
            states.append(physics_state(scene.model, scene.data))
        replayed = np.array(states)
        assert replayed.shape == recorded.shape, condition
        same = np.all(replayed == recorded, axis=1)
        assert same.all(), (condition, int(np.argmin(same)))
