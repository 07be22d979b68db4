"""The Franka Hand at its datasheet strength (70 N continuous grasp force), measured from raw MuJoCo data: the
pads' normal force against the command, a close → lift → carry → 5 s hold per object category (slip, tilt,
penetration), and nothing but the fingers holding a grasped object (no weld, equality constraint, attachment
or applied force in the models or on the code path)."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest

from mgdata.sim import robot
from mgdata.sim.scene import build_scene
from mgdata.sim.taskspec import ObjectPlacement
from tests.helpers.grip import carton_between_pads, pad_forces, scripted_grip, source_files
from tests.helpers.sim_tasks import task_with

GRASP_FORCE = 70.0
"""N per finger: the Franka Hand's continuous grasp force."""
TOLERANCE = 0.05
"""Relative: the servo gives 140 N + 100 N/m × tendon length on the tendon, i.e. 70–72 N per finger over the
hand's stroke, and contact forces of a held object fluctuate by ~1 N."""


def test_pad_force_follows_the_command_and_reaches_the_datasheet_70_N() -> None:
    scene, ctl, q = carton_between_pads()
    m, d = scene.model, scene.data
    grip = m.actuator(robot.GRIPPER_ACTUATOR).id
    gain, bias = m.actuator_gainprm[grip, 0], m.actuator_biasprm[grip, :2]
    finger_q = robot.finger_qpos_adr(m)
    body = scene.object_body("box")
    measured = {}
    for command in (1.0, 0.8, 0.6, 1.0):
        for _ in range(20):
            ctl.apply(np.array([*q, command]))
            ctl.step()
        left, right = pad_forces(m, d, body)
        # What the servo pushes on the split tendon (length = mean finger opening), half of it per finger.
        tendon = gain * d.ctrl[grip] + bias[0] + bias[1] * d.qpos[finger_q].mean()
        expected = -tendon / 2.0
        pads = (left, right)
        assert pads == pytest.approx((expected, expected), rel=TOLERANCE), \
            f"command {command}: pads {left:.1f} / {right:.1f} N, servo {expected:.1f} N per finger"
        measured[command] = (left + right) / 2.0
    closed = measured[1.0]
    assert closed == pytest.approx(GRASP_FORCE, rel=TOLERANCE), f"closed: {closed:.1f} N per finger"
    assert measured[0.6] < measured[0.8] < measured[1.0]
    assert abs(d.actuator_force[grip]) <= m.actuator_forcerange[grip, 1]  # the force range does not clip it


GRIPS = [  # one graspable object per category, by a grasp the check found valid
    ("jar/hinged_03", "side_000_r1"),
    pytest.param("box/carton_00", "top_r0", marks=pytest.mark.slow),
    pytest.param("sponge/block_00", "top_r0", marks=pytest.mark.slow),
    pytest.param("bottle/round_00", "side_000_r0", marks=pytest.mark.slow),
    pytest.param("cup/tumbler_00", "side_000_r1", marks=pytest.mark.slow),
    pytest.param("mug/handled_00", "rim_045_r0", marks=pytest.mark.slow),
    pytest.param("lid/tub_00", "knob_x_r0", marks=pytest.mark.slow),
    pytest.param("lid/canister_00", "knob_x_r0", marks=pytest.mark.slow),  # its knob only, above the plate
    pytest.param("container/bottle_00", "side_000_r1", marks=pytest.mark.slow),
    pytest.param("tray/flat_00", "rim_px_r0", marks=pytest.mark.slow),  # 24 x 16 cm, held by one side
    pytest.param("bowl/round_05", "wall_000_r0", marks=pytest.mark.slow),  # along its wall (vertical: 18°)
    pytest.param("container/lunchbox_00", "end_p_r1", marks=pytest.mark.slow),  # 15 cm long, held by one end
    pytest.param("holder/towel_00", "top_p_r0", marks=pytest.mark.slow),  # 31 cm long, by its bar, off centre
    pytest.param("board/chopping_00", "edge_px_r0", marks=pytest.mark.slow),  # 0.68 kg, by an overhanging end
    pytest.param("plate/flat_00", "edge_000_r0", marks=pytest.mark.slow),  # by its rim, overhanging
]


@pytest.mark.parametrize(("model", "grasp"), GRIPS)
def test_a_grasped_object_stays_put_through_lift_carry_and_a_5_s_hold(model: str, grasp: str) -> None:
    run = scripted_grip(model, grasp)
    assert run.rise > 0.08, f"{model}: rose {run.rise * 100:.1f} of 10 cm"
    assert run.max_penetration < 0.001, f"{model}: pads {run.max_penetration * 1000:.2f} mm deep"
    assert run.slip_hold <= 0.003, f"{model}: slipped {run.slip_hold * 1000:.2f} mm in the hand over 5 s"
    assert run.max_tilt_deg <= 10.0, f"{model}: tilted {run.max_tilt_deg:.1f}°"
    assert min(run.pad_force) > 0.9 * GRASP_FORCE, f"{model}: pads {run.pad_force} N"
    assert run.max_external == 0.0


def test_no_weld_equality_or_applied_force_holds_a_grasped_object() -> None:
    # The models: the only equality constraint couples the two finger joints; none names an object.
    models = ["jar/hinged_03", "bowl/round_05", "plate/flat_00", "tray/flat_00", "board/chopping_00",
              "lid/tub_00",
              "container/tub_00", "cabinet/drawer_00", "mug/handled_00", "holder/towel_00"]
    for name in models:
        scene = build_scene(task_with(ObjectPlacement("object", name, (0.6, 0.0, 0.0))))
        m = scene.model
        fingers = {m.joint(j).id for j in robot.FINGER_JOINTS}
        for e in range(m.neq):
            assert m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT, f"{name}: equality {e} of type {m.eq_type[e]}"
            assert {int(m.eq_obj1id[e]), int(m.eq_obj2id[e])} == fingers
        assert not scene.data.xfrc_applied.any() and not scene.data.qfrc_applied.any()
    # The code path: nothing in the package or the teleop tools writes an applied force, switches an equality
    # constraint or adds one (a grasp is the fingers' friction alone).
    forbidden = re.compile(r"xfrc_applied|qfrc_applied|mj_applyFT|eq_active\s*\[|add_equality|mjEQ_WELD")
    offenders = [f"{p}:{i + 1}" for p in source_files() for i, line in enumerate(p.read_text().splitlines())
                 if forbidden.search(line) and not line.lstrip().startswith(("#", '"', "*"))]
    assert not offenders, offenders
