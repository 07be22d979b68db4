"""Rendering: every camera sees what it must, images differ across cameras, the rig cleans up."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.cameras import CAMERA_NAMES, THIRD_PERSON, WRIST, WRIST_BODY_GEOM
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import Scene

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
