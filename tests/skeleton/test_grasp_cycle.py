"""``grasp_cycle``: pick-and-carry's draws cycle through the k reachable grasps whose pre-grasp the arm
reaches nearest its home posture, reached on that branch (0, the recipes' default: every reachable grasp,
round-robin). The hinted configuration is checked with raw MuJoCo forward kinematics against the
pre-grasp pose."""

from __future__ import annotations

import dataclasses

import mujoco  # after mgdata (conftest imports it first: it sets MUJOCO_GL)
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.errors import RecipeError
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir, recipes_dir
from mgdata.sim.robot import HOME_Q, TCP_SITE
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeleton.variation import draw_variation
from skeletons.jar import JarSkeleton


@pytest.fixture(scope="module")
def jar_executor() -> Executor:
    recipe = load_family_recipe("jar")
    return Executor(base_task(recipe, 0), recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)


def _ctx(ex: Executor, draw: int, cycle: int) -> Context:
    ex.scene.reset()
    ex.planner.sync(ex.scene.data)
    task = dataclasses.replace(ex.task, params={**ex.task.params, "grasp_cycle": cycle})
    var = draw_variation(task.family, task.task_id, draw, 0, ex.recipe.variation)
    return Context(task, ex.scene, ex.planner, var, ex.grasps, ex.scene.arm_q())


def test_a_recipe_read_without_its_skeleton_check_gets_the_default(jar_executor: Executor) -> None:
    """``load_recipe`` (tests, tools) fills no skeleton defaults: the pick runs as with grasp_cycle 0."""
    ctx = _ctx(jar_executor, 1, 0)
    ctx = dataclasses.replace(ctx, task=dataclasses.replace(
        ctx.task, params={k: v for k, v in ctx.task.params.items() if k != "grasp_cycle"}))
    carry = JarSkeleton.carry
    assert carry.choose_grasp(ctx).id == carry.choose_grasp(_ctx(jar_executor, 1, 0)).id
    assert not ctx.q_hints


def test_cycle_zero_is_round_robin_over_every_reachable_grasp(jar_executor: Executor) -> None:
    carry = JarSkeleton.carry
    reachable = carry.reachable_grasps(_ctx(jar_executor, 0, 0))
    assert len(reachable) >= 3
    picks = []
    for draw in range(len(reachable)):
        ctx = _ctx(jar_executor, draw, 0)
        picks.append(carry.choose_grasp(ctx).id)
        assert not ctx.q_hints
    assert picks == [g.id for g in carry._reachable(_ctx(jar_executor, 0, 0))]


def test_cycle_one_takes_one_grasp_reached_from_the_home_branch(jar_executor: Executor) -> None:
    carry = JarSkeleton.carry
    ex = jar_executor
    chosen, hints = set(), []
    for draw in range(3):
        ctx = _ctx(ex, draw, 1)
        grasp = carry.choose_grasp(ctx)
        chosen.add(grasp.id)
        hints.append(ctx.q_hints["pre_grasp"])
    assert len(chosen) == 1
    np.testing.assert_allclose(hints[0], hints[1], atol=0)  # the task's seed: every draw the same branch
    # the hint puts the TCP at the pre-grasp pose (raw MuJoCo forward kinematics on the scene's own model)
    ctx = _ctx(ex, 0, 1)
    grasp = carry.choose_grasp(ctx)
    model = ex.scene.model
    data = mujoco.MjData(model)
    data.qpos[:] = ex.scene.data.qpos
    data.qpos[:7] = hints[0]
    mujoco.mj_kinematics(model, data)
    jar = model.body("jar").id
    obj = np.eye(4)
    obj[:3, :3] = data.xmat[jar].reshape(3, 3)
    obj[:3, 3] = data.xpos[jar]
    tcp_target = obj @ grasp.matrix()
    standoff = float(ctx.param("reach_standoff"))
    expected = tcp_target[:3, 3] - standoff * tcp_target[:3, 2]
    site = model.site(TCP_SITE).id
    assert np.linalg.norm(data.site_xpos[site] - expected) < 2e-3
    # and it is the home-nearest branch among the grasps the cycle of two takes
    two = {carry.choose_grasp(c := _ctx(ex, d, 2)).id: c.q_hints["pre_grasp"] for d in range(2)}
    assert len(two) == 2 and grasp.id in two
    dist = {g: float(np.linalg.norm(q - HOME_Q)) for g, q in two.items()}
    assert dist[grasp.id] == min(dist.values())


def test_recipes_without_the_key_read_zero_and_bad_values_are_refused(tmp_path) -> None:
    import shutil

    assert load_family_recipe("jar").params["grasp_cycle"] == 0
    shutil.copytree(recipes_dir() / "specs", tmp_path / "specs")
    text = (recipes_dir() / "jar.toml").read_text()
    for value, ok in (("2", True), ("-1", False), ("1.5", False)):
        cycle = f"[params]\ngrasp_cycle = {value}\n"
        (tmp_path / "jar.toml").write_text(text.replace("[params]\n", cycle, 1))
        if ok:
            assert load_family_recipe(tmp_path / "jar.toml").params["grasp_cycle"] == 2
        else:
            with pytest.raises(RecipeError, match="grasp_cycle"):
                load_family_recipe(tmp_path / "jar.toml")
