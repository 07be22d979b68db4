"""Rendering: every camera sees what it must, images differ across cameras, the rig cleans up."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.cameras import CAMERA_NAMES, THIRD_PERSON
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
