"""Determinism: one scripted rollout in two freshly built scenes gives bit-identical states and images."""

from __future__ import annotations

import numpy as np

from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import build_scene
from tests.helpers.sim_tasks import ik, jar_task

DOWN = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])


def rollout() -> tuple[np.ndarray, list[dict[str, np.ndarray]]]:
    """Push the fingers into the open jar, close the gripper and pull up (many contacts); qpos every step,
    images every 5th."""
    scene = build_scene(jar_task())
    scene.reset()
    ctl = JointController(scene)
    jar = scene.objects["jar"].geometry
    x = 0.5 - jar["outer_radius"] + 0.02
    q = robot.HOME_Q
    qpos, images = [], []
    with CameraRig(scene, size=64) as rig:
        for t in range(30):
            z = jar["grasp_height"] + (0.1 if t < 10 else 0.0) + (0.004 * (t - 20) if t > 20 else 0.0)
            q = ik(q, (x, 0.0, z), DOWN)
            ctl.apply(np.array([*q, 1.0 if t >= 14 else 0.0]))
            ctl.step()
            qpos.append(scene.data.qpos.copy())
            if t % 5 == 4:
                images.append(rig.render())
    return np.array(qpos), images


def test_two_runs_are_bit_identical() -> None:
    qpos_a, images_a = rollout()
    qpos_b, images_b = rollout()
    assert np.array_equal(qpos_a, qpos_b)
    assert np.abs(np.diff(qpos_a, axis=0)).max() > 1e-3, "the rollout must actually move things"
    for a, b in zip(images_a, images_b, strict=True):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
