"""The initial-state gate rejects what cannot be done safely, for the reason it states, and redraws.

Each rejected case is built so that the reason holds physically (checked here from raw MuJoCo where it is
a physical claim): an object that starts on the floor, a jar out of the arm's reach, a task whose grasps are
all missing. Accepted tasks: the accepted draw is the first that passes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mgdata.engine.init_gate import Infeasible, base_task, cached_grasp_db, check_initial_state
from mgdata.errors import RecipeError
from mgdata.paths import grasps_dir
from mgdata.sim.scene import build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.sim.world import FLOOR_Z
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.base import draw_task
from mgdata.tasks.placer import LayoutRejected


@pytest.fixture(scope="module")
def jar():  # type: ignore[no-untyped-def]
    return load_family_recipe("jar")


def _moved(task, name: str, pos: tuple[float, float, float]):  # type: ignore[no-untyped-def]
    objects = tuple(dataclasses.replace(o, pos=pos) if o.name == name else o for o in task.objects)
    return dataclasses.replace(task, objects=objects)


def test_an_object_starting_on_the_floor_fails_the_safe_start(jar) -> None:  # type: ignore[no-untyped-def]
    task = draw_task(jar, 0)
    jar_pos = task.object("jar").pos
    # the jar (and its food) on the floor beside the table
    task = _moved(_moved(task, "jar", (1.3, jar_pos[1], FLOOR_Z)), "food", (1.3, jar_pos[1], FLOOR_Z + 0.007))
    scene = build_scene(task)
    assert scene.object_pose("jar")[0][2] < FLOOR_Z + 0.05  # physically on the floor after the settle
    with pytest.raises(Infeasible) as err:
        check_initial_state(task, jar, cached_grasp_db(grasps_dir()))
    assert err.value.rule == "init.safe" and "jar_not_dropped" in err.value.why


def test_a_jar_out_of_reach_fails_the_reach_check(jar) -> None:  # type: ignore[no-untyped-def]
    task = draw_task(jar, 0)
    far = (1.0, 0.0, 0.0)  # 1 m in front of the base: beyond the Panda's ~0.85 m reach at table height
    task = _moved(_moved(task, "jar", far), "food", (far[0], far[1], task.object("food").pos[2]))
    with pytest.raises(Infeasible) as err:
        check_initial_state(task, jar, cached_grasp_db(grasps_dir()))
    assert err.value.rule == "reach.grasps" and "0 of the" in err.value.why


def test_without_grasps_no_draw_passes_and_the_error_names_the_rule(jar, tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(RecipeError) as err:
        base_task(dataclasses.replace(jar, tasks=dataclasses.replace(jar.tasks, max_draws=3)), 0, tmp_path)
    message = str(err.value)
    assert "task 0 failed the initial-state gate on all 3 draws" in message
    assert "reach.grasps: 0 of the 0 valid grasps of jar are reachable" in message


def test_the_accepted_draw_is_the_first_that_passes() -> None:
    recipe = load_family_recipe("clutter_liquid")
    db = cached_grasp_db(grasps_dir())
    for k in (0, 1):
        task = base_task(recipe, k)
        facts = check_initial_state(draw_task(recipe, k, task.draw), recipe, db)
        assert tuple(facts["grasps"]) == tuple(task.gate["grasps"])
        for d in range(task.draw):
            with pytest.raises((Infeasible, LayoutRejected)):
                check_initial_state(draw_task(recipe, k, d), recipe, db)


def test_gated_tasks_are_deterministic(jar) -> None:  # type: ignore[no-untyped-def]
    a = base_task(jar, 2)
    b = check_initial_state(draw_task(jar, 2, a.draw), jar, cached_grasp_db(grasps_dir()))
    assert tuple(b["grasps"]) == tuple(a.gate["grasps"])
    assert isinstance(a.objects[0], ObjectPlacement) and np.isfinite(a.goal.radius)
