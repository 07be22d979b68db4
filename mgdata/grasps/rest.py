"""Rest targets: the TCP pose to command so that the arm comes to rest at a grasp's pose.

The arm's position servos do not compensate gravity (:mod:`mgdata.sim.servo`): commanded to a pose, the arm
rests below it, ≈ 5 mm over the middle of the table and ≈ 13 mm stretched out to its far side. Where a grasp
must land where the grasp database puts it (an edge pinch across a board's 12-20 mm thickness, a knob grasp
whose fingertips stay a few millimetres above the lid's plate), the approach aims at the pose under which the
arm rests there instead: the forward kinematics of :meth:`~mgdata.sim.servo.ArmServo.rest_command` of the
pose's IK solution. The edge pick (:mod:`mgdata.skeleton.edge_pick`), the grasp check of an edge pinch
(:mod:`mgdata.grasps.check`) and the lid's knob grasp (``skeletons/lid.py``) use it.

Example::

    target = resting_target(planner, scene.model, grasp_pose, (q_now, HOME_Q), rng)   # the arm rests there
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from mgdata.motion import MotionFailure, MotionPlanner, Pose
from mgdata.sim.servo import ArmServo


def resting_target(planner: MotionPlanner, model: mujoco.MjModel, pose: Pose,
                   seeds: Sequence[np.ndarray], rng: np.random.Generator) -> Pose:
    """The TCP pose whose command leaves the arm, pushing on nothing, at rest at ``pose``, from its IK
    solution near the first of ``seeds`` that has one (a half-turn-rolled pinch is often out of the solver's
    reach from where a push leaves the arm, not from home); ``pose`` itself where none has (a plan to it then
    fails as it would have)."""
    q = first_ik(planner, pose, seeds, rng)
    return pose if q is None else planner.fk(ArmServo(model).rest_command(q))


def first_ik(planner: MotionPlanner, pose: Pose, seeds: Sequence[np.ndarray], rng: np.random.Generator, *,
             collision_free: bool = False) -> np.ndarray | None:
    """An IK solution for ``pose`` near the first of ``seeds`` that has one (``None`` where none has)."""
    for seed in seeds:
        try:
            return planner.ik(pose, seed, rng, collision_free=collision_free)
        except MotionFailure:
            continue
    return None
