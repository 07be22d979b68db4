"""Rendering: every camera sees what it must, images differ across cameras, the rig cleans up; the faster
path (coarse tessellation, far level of detail) is deterministic, invisible where meant, physics-free."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from mgdata.errors import RecipeError, SceneError
from mgdata.sim import robot
from mgdata.sim.cameras import CAMERA_NAMES, THIRD_PERSON, WRIST, WRIST_BODY_GEOM
from mgdata.sim.controller import JointController
from mgdata.sim.render_config import RenderConfig
from mgdata.sim.renderer import CameraRig, camera_option, context_model
from mgdata.sim.scene import Scene, build_scene
from tests.helpers.repo import REPO

MIN_PIXELS = 20


def _visible(scene: Scene, camera: str) -> dict[str, int]:
    """Pixels per thing in a segmentation render of ``camera`` (256²)."""
    m = scene.model
    r = mujoco.Renderer(m, 256, 256)
    try:
        r.enable_segmentation_rendering()
        r.update_scene(scene.data, camera=camera)
        seg = r.render()
    finally:
        r.close()
    geoms = seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM]
    body = m.geom_bodyid[geoms]
    jar = [scene.object_body("jar"), m.body("jar/lid").id]
    return {
        "robot": int(np.isin(body, robot.robot_body_ids(m)).sum()),
        "table": int((body == m.body("table").id).sum()),
        "jar": int(np.isin(body, jar).sum()),
        "goal": int((geoms == m.geom("goal").id).sum()),
    }


@pytest.mark.parametrize("camera", CAMERA_NAMES)
def test_camera_sees_robot_table_jar_and_goal(jar_scene: Scene, camera: str) -> None:
    jar_scene.reset()
    seen = _visible(jar_scene, camera)
    required = ("robot", "table", "jar", "goal") if camera in THIRD_PERSON else ("robot", "table")
    missing = {k: seen[k] for k in required if seen[k] < MIN_PIXELS}
    assert not missing, f"camera {camera!r} barely sees {missing} (pixels: {seen})"


def test_rgb_images_are_lit_distinct_and_deterministic(jar_scene: Scene) -> None:
    jar_scene.reset()
    with CameraRig(jar_scene) as rig:
        first = rig.render()
        again = rig.render()
    assert list(first) == list(CAMERA_NAMES)
    for name, img in first.items():
        assert img.shape == (256, 256, 3) and img.dtype == np.uint8
        assert 30 < img.mean() < 220 and img.std() > 20, f"{name} is blank or washed out"
        assert np.array_equal(img, again[name])
    names = list(first)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            assert np.abs(first[a].astype(int) - first[b].astype(int)).mean() > 10, f"{a} looks like {b}"


def test_rig_errors_and_close(jar_scene: Scene) -> None:
    with pytest.raises(SceneError, match="unknown camera"):
        CameraRig(jar_scene, cameras=("front", "ceiling"))
    rig = CameraRig(jar_scene, cameras=("wrist",), size=32)
    assert rig.render()["wrist"].shape == (32, 32, 3)
    rig.close()
    rig.close()
    with pytest.raises(SceneError, match="after close"):
        rig.render()


def test_wrist_camera_sits_on_its_body_behind_the_fingertips(jar_scene: Scene) -> None:
    """The wrist camera is mounted like a real one: its eye on the front face of a colliding camera body
    bolted outside the hand's shell, behind the fingers, seeing both fingertips."""
    jar_scene.reset()
    m, d = jar_scene.model, jar_scene.data
    hand, cam, body = m.body(robot.HAND_BODY).id, m.camera(WRIST).id, m.geom(WRIST_BODY_GEOM).id
    assert m.cam_bodyid[cam] == hand and m.geom_bodyid[body] == hand
    assert body in robot.robot_geom_ids(m)  # collides: planning keeps it out of the table and objects
    front = m.geom_pos[body] + np.array([0.0, 0.0, m.geom_size[body, 2]])
    assert np.allclose(m.cam_pos[cam], front)  # the eye is on the body's front face (hand frame)
    fingers = [m.body(b).id for b in robot.FINGER_BODIES]
    assert m.cam_pos[cam][2] < m.body_pos[fingers[0]][2]  # behind the fingers along the approach axis
    shell = [g for g in range(m.ngeom) if m.geom_bodyid[g] == hand and m.geom_contype[g] and g != body]
    assert min(mujoco.mj_geomDistance(m, d, body, g, 0.05, None) for g in shell) > 0.0  # outside the hand
    r = mujoco.Renderer(m, 256, 256)
    try:
        r.enable_segmentation_rendering()
        r.update_scene(d, camera=WRIST)
        seg = r.render()
    finally:
        r.close()
    seen = m.geom_bodyid[seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM]]
    assert all((seen == f).sum() >= MIN_PIXELS for f in fingers), "the wrist camera does not see both fingers"


# -- the faster render path (issue 16; docs/render.md) ------------------------------------------------------

SHEET_SCRIPT = """
import hashlib, sys
sys.path.insert(0, {tests!r})
from tests.helpers.sim_tasks import jar_task
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import build_scene
scene = build_scene(jar_task())
scene.reset()
with CameraRig(scene) as rig:
    images = rig.render()
print(hashlib.sha256(b"".join(images[c].tobytes() for c in images)).hexdigest())
"""


def _near_only(task_scene: Scene) -> Scene:
    """The same task built with the far level of detail off."""
    sim = task_scene.sim
    return build_scene(task_scene.task, sim=dataclasses.replace(sim, render=dataclasses.replace(sim.render,
                                                                                               far_lod=0.0)))


def _reference(scene: Scene) -> dict[str, np.ndarray]:
    """The render path before issue 16: a plain ``mujoco.Renderer`` on the scene's model."""
    r = mujoco.Renderer(scene.model, 256, 256)
    try:
        r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        out = {}
        for cam in CAMERA_NAMES:
            r.update_scene(scene.data, camera=cam)
            out[cam] = r.render().copy()
        return out
    finally:
        r.close()


def test_images_are_byte_identical_in_a_fresh_process(jar_scene: Scene) -> None:
    jar_scene.reset()
    with CameraRig(jar_scene) as rig:
        images = rig.render()
    here = hashlib.sha256(b"".join(images[c].tobytes() for c in images)).hexdigest()
    script = SHEET_SCRIPT.format(tests=str(REPO))
    env = {**os.environ, "LP_NUM_THREADS": "1"}
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == here


def test_coarse_tessellation_is_invisible_next_to_the_reference_path(jar_scene: Scene) -> None:
    """Tolerance (measured in docs/render.md): per camera mean ≤ 3 levels, ≤ 0.2 % of pixels off by > 8."""
    scene = _near_only(jar_scene)
    scene.reset()
    with CameraRig(scene) as rig:
        fast = rig.render()
    slow = _reference(scene)
    for cam in CAMERA_NAMES:
        diff = np.abs(fast[cam].astype(int) - slow[cam].astype(int)).max(axis=-1)
        assert diff.mean() <= 3.0 and (diff > 8).mean() <= 0.002, (cam, diff.mean(), (diff > 8).mean())


def test_context_model_carries_the_tessellation_and_leaves_the_scene_alone(jar_scene: Scene) -> None:
    config = RenderConfig(plane_grid=3.0, numslices=12, numstacks=6, numquads=2)
    m = jar_scene.model
    before = (m.geom_size.copy(), m.vis.quality.numslices, m.vis.global_.offwidth)
    ctx = context_model(m, 96, config)
    floor = m.geom("floor").id
    assert ctx.geom_size[floor, 2] == 3.0 and m.geom_size[floor, 2] != 3.0
    assert (ctx.vis.quality.numslices, ctx.vis.quality.numstacks, ctx.vis.quality.numquads) == (12, 6, 2)
    assert (ctx.vis.global_.offwidth, ctx.vis.global_.offheight) == (96, 96)
    assert np.array_equal(before[0], m.geom_size) and before[1:] == (m.vis.quality.numslices,
                                                                       m.vis.global_.offwidth)


def _robot_geoms_seen(scene: Scene, camera: str, option: mujoco.MjvOption) -> set[int]:
    r = mujoco.Renderer(scene.model, 128, 128)
    try:
        r.enable_segmentation_rendering()
        r.update_scene(scene.data, camera=camera, scene_option=option)
        seg = r.render()
    finally:
        r.close()
    geoms = np.unique(seg[..., 0][seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM])
    m = scene.model
    return {int(g) for g in geoms if m.geom_bodyid[g] in set(robot.robot_body_ids(m).tolist())}


def test_far_cameras_draw_the_far_level_and_near_ones_the_near_level(jar_scene: Scene) -> None:
    m = jar_scene.model
    config = jar_scene.sim.render
    assert config.far_lod > 0, "recipes/sim.toml ships a far level of detail"
    far = np.flatnonzero(m.geom_group == robot.FAR_LOD_GROUP)
    robot_geom = np.isin(m.geom_bodyid, robot.robot_body_ids(m))
    near = np.flatnonzero((m.geom_group == robot.NEAR_LOD_GROUP) & robot_geom)
    assert len(far) == len(near) > 20
    assert not (m.geom_contype[far] | m.geom_conaffinity[far]).any()
    faces = m.mesh_facenum
    assert faces[m.geom_dataid[far]].sum() < 0.7 * faces[m.geom_dataid[near]].sum()
    jar_scene.reset()
    expected_far = {"front": True, "left": True, "right": True, "shoulder": True, "wrist": False}
    for cam, is_far in expected_far.items():
        option = camera_option(m, m.camera(cam).id, config)
        seen = _robot_geoms_seen(jar_scene, cam, option)
        assert seen & set((far if is_far else near).tolist()), (cam, is_far)
        assert not seen & set((near if is_far else far).tolist()), (cam, is_far)
    off = camera_option(m, m.camera("front").id, dataclasses.replace(config, far_lod=0.0))
    assert off.geomgroup[robot.NEAR_LOD_GROUP] and not off.geomgroup[robot.FAR_LOD_GROUP]
    plain = _near_only(jar_scene).model  # e.g. a scene stored before the far level existed
    kept = camera_option(plain, plain.camera("front").id, config)
    assert kept.geomgroup[robot.NEAR_LOD_GROUP] and not kept.geomgroup[robot.FAR_LOD_GROUP]


def test_the_far_level_does_not_change_physics(jar_scene: Scene) -> None:
    """Same scripted motion with and without the far-level geoms: bit-identical states, with contacts."""

    def roll(scene: Scene) -> np.ndarray:
        scene.reset()
        ctl = JointController(scene)
        states = []
        for t in range(40):
            ctl.apply(np.array([*(robot.HOME_Q + 0.3 * np.sin(t / 6.0)), float(t > 15)]))
            ctl.step()
            assert scene.data.ncon > 0
            states.append(scene.snapshot())
        return np.array(states)

    plain = _near_only(jar_scene)
    assert plain.model.ngeom < jar_scene.model.ngeom
    assert np.array_equal(roll(jar_scene), roll(plain))


@pytest.mark.parametrize(("key", "value", "message"), [
    ("plane_grid", 0.0, "plane_grid = 0.0: expected a positive number"),
    ("numslices", 2, "numslices = 2: expected an integer >= 3"),
    ("numquads", 0, "numquads = 0: expected an integer >= 1"),
    ("far_lod", 1.5, r"far_lod = 1.5: expected a fraction in \[0, 1\)"),
    ("far_lod_distance", -1.0, "far_lod_distance = -1.0: expected a number >= 0"),
])
def test_bad_render_settings_are_one_error(key: str, value: float, message: str) -> None:
    with pytest.raises(RecipeError, match=message):
        RenderConfig(**{key: value})
