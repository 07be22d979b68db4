"""JointController: the 8-D action/state interface and its failure modes."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.errors import MgdataError, SimulationError
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene, build_scene
from tests.helpers.sim_tasks import jar_task


def test_action_maps_to_actuators_and_state_tracks_it(jar_scene: Scene) -> None:
    jar_scene.reset()
    ctl = JointController(jar_scene)
    target = robot.HOME_Q + np.array([0.2, -0.1, 0.0, 0.1, 0.0, 0.0, -0.3])
    ctl.apply(np.array([*target, 1.0]))
    ids = robot.arm_actuator_ids(jar_scene.model)
    assert np.allclose(jar_scene.data.ctrl[ids[:7]], target)
    assert jar_scene.data.ctrl[ids[7]] == pytest.approx(jar_scene.gripper.closed_ctrl)
    t0 = jar_scene.data.time
    for _ in range(20):
        ctl.step()
    assert jar_scene.data.time == pytest.approx(t0 + 20 * 0.05)
    state = ctl.state()
    assert state.dtype == np.float32 and state.shape == (8,)
    assert np.allclose(state[:7], target, atol=0.02)
    assert state[7] < 0.002  # closed on nothing: fingers meet
    ctl.apply(np.array([*target, 0.0]))
    for _ in range(17):  # 0.1 m/s of opening width: 8 cm in 0.8 s (16 steps)
        ctl.step()
    assert ctl.state()[7] == pytest.approx(robot.GRIPPER_MAX_OPENING, abs=3e-3)


def test_targets_are_clipped_to_joint_ranges(jar_scene: Scene) -> None:
    jar_scene.reset()
    ctl = JointController(jar_scene)
    ctl.apply(np.array([9.0, 9.0, 9.0, 9.0, 9.0, 9.0, 9.0, 0.5]))
    ids = robot.arm_actuator_ids(jar_scene.model)
    assert np.all(jar_scene.data.ctrl[ids[:7]] <= jar_scene.model.actuator_ctrlrange[ids[:7], 1])


@pytest.mark.parametrize("bad", [np.zeros(7), np.full(8, np.nan), np.zeros((2, 8))])
def test_bad_action_is_rejected(jar_scene: Scene, bad: np.ndarray) -> None:
    with pytest.raises(MgdataError, match="8 finite numbers"):
        JointController(jar_scene).apply(bad)


def test_divergence_raises_instead_of_silently_resetting() -> None:
    scene = build_scene(jar_task(open_fraction=0.0))
    ctl = JointController(scene)
    jar = scene.object_body("jar")
    ctl.apply(np.array([*robot.HOME_Q, 0.0]))
    with pytest.raises(SimulationError, match="diverged"):
        for _ in range(40):  # an absurd 1.5 N·m spin on a 0.3 kg jar: ~1000 rad/s
            scene.data.xfrc_applied[jar, 3:] = [1.5, 0.0, 0.0]
            ctl.step()
