"""The Franka Hand's grip, measured from raw MuJoCo data (docs/sim.md "Gripper"): the pads' normal force
(``mujoco.mj_contactForce``, summed per finger) against the gripper command on a carton held top-down, and
a close → lift 10 cm → carry 15 cm → 5 s hold per object category (rise, tilt, slip in the hand over the
hold, deepest finger contact).

    LP_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python benchmarks/grip_force.py [--grips]
"""

from __future__ import annotations

import sys

import numpy as np

import mgdata  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
from mgdata.sim import robot
from tests.helpers.grip import carton_between_pads, pad_forces, scripted_grip
from tests.sim.test_grip_force import GRIPS

COMMANDS = (0.5, 0.55, 0.6, 0.7, 0.8, 0.9, 1.0)


def force_table() -> None:
    scene, ctl, q = carton_between_pads()
    m, d = scene.model, scene.data
    grip = m.actuator(robot.GRIPPER_ACTUATOR).id
    print("| command | actuator ctrl | tendon force (N) | left pad (N) | right pad (N) | width (mm) |")
    print("|---|---|---|---|---|---|")
    for command in (*reversed(COMMANDS), 1.0):
        for _ in range(20):
            ctl.apply(np.array([*q, command]))
            ctl.step()
        left, right = pad_forces(m, d, scene.object_body("box"))
        width = d.qpos[robot.finger_qpos_adr(m)].sum() * 1000
        print(f"| {command:.2f} | {d.ctrl[grip]:.2f} | {d.actuator_force[grip]:.1f} | {left:.1f} | "
              f"{right:.1f} | "
              f"{width:.1f} |")


def grip_table() -> None:
    print("| object | grasp | rise (cm) | max tilt (°) | slip over 5 s hold (mm) | deepest pad contact (mm) "
          "| pads (N) |")
    print("|---|---|---|---|---|---|---|")
    for p in GRIPS:
        model, grasp = p.values if hasattr(p, "values") else p
        r = scripted_grip(model, grasp)
        print(f"| {model} | {grasp} | {r.rise * 100:.1f} | {r.max_tilt_deg:.1f} | {r.slip_hold * 1000:.2f} | "
              f"{r.max_penetration * 1000:.2f} | {r.pad_force[0]:.0f} / {r.pad_force[1]:.0f} |")


if __name__ == "__main__":
    force_table()
    if "--grips" in sys.argv:
        grip_table()
