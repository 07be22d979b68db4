"""The scene builder: naming contract, initial state, snapshots, and clear errors for bad tasks."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from mgdata.errors import AssetError, SceneError
from mgdata.sim import robot
from mgdata.sim.cameras import CAMERA_NAMES
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.sim.world import TABLE_TOP_Z
from tests.helpers.sim_tasks import jar_task


def test_naming_contract(jar_scene: Scene) -> None:
    m = jar_scene.model
    for kind, name in [("body", "table"), ("body", "jar"), ("body", "jar/lid"), ("joint", "jar/lid_hinge"),
                       ("joint", "jar/free"), ("body", "food"), ("body", "goal"), ("site", "goal"),
                       ("geom", "goal"), ("site", robot.TCP_SITE), *(("camera", c) for c in CAMERA_NAMES)]:
        assert getattr(m, kind)(name).id >= 0
    goal = m.geom("goal").id
    assert m.geom_contype[goal] == 0 and m.geom_conaffinity[goal] == 0
    assert jar_scene.object_names == ("jar", "food")
    assert set(jar_scene.object_geom_ids("jar")) >= {m.geom("jar/lid").id}
    assert not set(jar_scene.object_geom_ids("jar")) & set(jar_scene.robot_geom_ids)
    assert m.opt.timestep <= 1 / 120 and m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def test_reset_state(jar_scene: Scene) -> None:
    jar_scene.reset()
    assert np.allclose(jar_scene.arm_q(), robot.HOME_Q, atol=0.02)
    assert jar_scene.gripper_opening() == pytest.approx(robot.GRIPPER_MAX_OPENING, abs=2e-3)
    assert jar_scene.articulation_fraction("jar") == pytest.approx(1.0, abs=0.02)
    pos, rot = jar_scene.object_pose("jar")
    assert np.allclose(pos, [0.5, 0.0, TABLE_TOP_Z], atol=2e-3) and rot[2, 2] > 0.999
    assert jar_scene.data.time == 0.0
    # The cherry rests inside the jar, on its floor.
    food = jar_scene.data.xipos[jar_scene.object_body("food")]
    assert np.hypot(food[0] - 0.5, food[1]) < jar_scene.objects["jar"].geometry["inner_radius"]


def test_snapshot_restore_is_exact(jar_scene: Scene) -> None:
    jar_scene.reset()
    m, d = jar_scene.model, jar_scene.data
    d.ctrl[0] = 0.5
    for _ in range(50):
        mujoco.mj_step(m, d)
    snap = jar_scene.snapshot()
    for _ in range(100):
        mujoco.mj_step(m, d)
    first = d.qpos.copy()
    jar_scene.restore(snap)
    for _ in range(100):
        mujoco.mj_step(m, d)
    assert np.array_equal(d.qpos, first)
    jar_scene.reset()
    again = jar_scene.snapshot()
    jar_scene.reset()
    assert np.array_equal(again, jar_scene.snapshot())


def test_closed_jar_builds_closed() -> None:
    scene = build_scene(jar_task(open_fraction=0.0))
    assert scene.articulation_fraction("jar") < 0.01


def test_unknown_model_is_one_clear_error() -> None:
    task = jar_task(extra=(ObjectPlacement("cup", "cup/does_not_exist", (0.3, 0.3, 0.0)),))
    with pytest.raises(AssetError, match="unknown object model 'cup/does_not_exist'"):
        build_scene(task)


def test_overlapping_initial_poses_are_rejected() -> None:
    task = jar_task(extra=(ObjectPlacement("jar2", "jar/hinged_05", (0.52, 0.0, 0.0)),))
    with pytest.raises(SceneError, match=r"initial poses overlap: 'jar2?' .* and 'jar2?'"):
        build_scene(task)


def test_object_sunk_into_table_is_rejected() -> None:
    task = jar_task(extra=(ObjectPlacement("cherry", "food/cherry_01", (0.3, 0.3, -0.01)),))
    with pytest.raises(SceneError, match=r"'table'.*'cherry'|'cherry'.*'table'"):
        build_scene(task)


@pytest.mark.parametrize(
    ("extra", "articulation", "message"),
    [
        ((ObjectPlacement("jar", "food/cherry_01", (0.3, 0.3, 0.0)),), None, "used twice"),
        ((ObjectPlacement("table", "food/cherry_01", (0.3, 0.3, 0.0)),), None, "not allowed"),
        ((), {"jar": 1.5}, "expected 0 .closed. … 1 .open."),
        ((), {"food": 0.5}, "has no articulation"),
        ((), {"nope": 0.5}, "not an object instance"),
    ],
)
def test_bad_task_entries(extra: tuple, articulation: dict | None, message: str) -> None:
    task = jar_task(extra=extra)
    if articulation is not None:
        task = dataclasses.replace(task, articulation=articulation)
    with pytest.raises(SceneError, match=message):
        build_scene(task)
