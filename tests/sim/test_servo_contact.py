"""ArmServo's rest command and the contact-force reading, against raw MuJoCo state."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.contact_force import geom_set, pair_contact
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.servo import ArmServo
from mgdata.sim.taskspec import ObjectPlacement
from tests.helpers.sim_tasks import task_with


@pytest.fixture(scope="module")
def box_scene() -> Scene:
    return build_scene(task_with(ObjectPlacement("box", "box/carton_00", (0.5, 0.0, 0.0), 0.0)))


def test_rest_command_holds_the_arm_where_asked_and_the_plain_command_sags(box_scene: Scene) -> None:
    scene, servo = box_scene, ArmServo(box_scene.model)
    ctl = JointController(scene)
    q = robot.HOME_Q + np.array([0.2, 0.3, -0.1, 0.2, 0.1, -0.2, 0.3])
    for command, expect_sag in ((q, True), (servo.rest_command(q), False)):
        scene.reset()
        for _ in range(60):  # 3 s
            ctl.apply(np.r_[command, 0.0])
            ctl.step()
        error = np.abs(scene.data.qpos[robot.arm_qpos_adr(scene.model)] - q).max()
        assert (error > 2e-3) if expect_sag else (error < 2e-4), error
    # and rest_pose inverts rest_command: where a plain command q lets the arm sag to
    assert np.allclose(servo.rest_pose(servo.rest_command(q)), q, atol=1e-9)
    scene.reset()
    for _ in range(60):
        ctl.apply(np.r_[q, 0.0])
        ctl.step()
    assert np.abs(scene.data.qpos[robot.arm_qpos_adr(scene.model)] - servo.rest_pose(q)).max() < 2e-4


def test_pair_contact_is_the_weight_of_a_box_resting_on_the_table(box_scene: Scene) -> None:
    scene = box_scene
    scene.reset()
    m, d = scene.model, scene.data
    box, table, hand = geom_set(scene, "box"), geom_set(scene, "table"), geom_set(scene, "hand")
    touching, newtons = pair_contact(m, d, box, table)
    body = m.body("box").id
    mass = m.body_subtreemass[body]
    assert touching and newtons == pytest.approx(mass * -m.opt.gravity[2], rel=0.02)
    assert pair_contact(m, d, hand, box) == (False, 0.0)
    # the hand set is the hand body and both fingers (raw body names), nothing else
    names = {m.body(int(m.geom_bodyid[g])).name for g in np.flatnonzero(hand)}
    assert names == {"hand", "left_finger", "right_finger"}
    with pytest.raises(SceneError, match="no object, body or fixed part named 'lid'"):
        geom_set(scene, "lid")


def test_a_body_name_selects_that_body_and_an_instance_all_its_bodies(jar_scene: Scene) -> None:
    m = jar_scene.model
    lid, jar = geom_set(jar_scene, "jar/lid"), geom_set(jar_scene, "jar")
    colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    body = np.array([m.body(int(b)).name for b in m.geom_bodyid])
    assert lid.any() and np.array_equal(lid, colliding & (body == "jar/lid"))
    assert np.array_equal(jar, colliding & np.isin(body, ["jar", "jar/lid"]))
