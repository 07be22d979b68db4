"""Context: what a skeleton sees while an attempt runs (the task, the live scene, the draws, the grasps).

The executor creates one per attempt. Skeletons read the live state through it (object and TCP poses, the
commanded arm configuration) and keep attempt-local choices in ``memo`` (e.g. the chosen grasp), never in
module globals, so attempts stay independent and reproducible.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from mgdata.motion.types import JointTrajectory, Pose
from mgdata.skeleton.task_rng import task_rng

if TYPE_CHECKING:
    from mgdata.grasps.db import Grasp
    from mgdata.motion import MotionPlanner
    from mgdata.sim.scene import Scene
    from mgdata.sim.taskspec import TaskSpec
    from mgdata.skeleton.variation import Variation


@dataclass
class Context:
    """The runtime context of one attempt.

    Attributes:
        task: the task being demonstrated.
        scene: the live MuJoCo scene (``scene.model``, ``scene.data``).
        planner: the motion facade (IK, free-space planning, lines), synced to the scene.
        variation: this attempt's random draws (``variation["lift_m"]``, ``variation.rng("grasp")``).
        grasps: the grasp database entries of each task object's model (instance name -> grasps).
        q_cmd: the arm configuration last commanded (7,); segments are planned from here.
        executed: segment name -> the joint trajectory it executed (for ``reverse``).
        memo: attempt-local scratch space for the skeleton (chosen grasp, measured geometry …).
        q_hints: runtime-target name -> an arm configuration (7,) the skeleton already found for it (e.g.
            while checking that a sequence of poses is reachable one after the other); the IK of a free
            segment to that target starts there, so it executes the branch that was checked.
    """

    task: TaskSpec
    scene: Scene
    planner: MotionPlanner
    variation: Variation
    grasps: Mapping[str, tuple[Grasp, ...]]
    q_cmd: np.ndarray
    executed: dict[str, JointTrajectory] = field(default_factory=dict)
    memo: dict[str, Any] = field(default_factory=dict)
    q_hints: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def params(self) -> Mapping[str, Any]:
        """The family tunables from the recipe (``TaskSpec.params``)."""
        return self.task.params

    def param(self, name: str) -> Any:
        """One tunable; a missing one is a recipe error naming the key."""
        from mgdata.errors import RecipeError

        if name not in self.task.params:
            raise RecipeError(f"recipes/{self.task.family}.toml: [params] has no key {name!r}")
        return self.task.params[name]

    def task_rng(self, name: str) -> np.random.Generator:
        """A generator for purpose ``name`` seeded by the task alone (:mod:`mgdata.skeleton.task_rng`): the
        gate and every attempt of the task draw the same stream."""
        return task_rng(self.task.seed, name)

    def object_pose(self, name: str) -> Pose:
        """The world pose of an object instance's root body, from the live state."""
        return Pose.from_pos_mat(*self.scene.object_pose(name))

    def body_pose(self, name: str) -> Pose:
        """The world pose of any body by its full name (``"jar/lid"``)."""
        body = self.scene.model.body(name).id
        data = self.scene.data
        return Pose(data.xpos[body].copy(), data.xquat[body].copy())

    def tcp_pose(self) -> Pose:
        """The measured world pose of the TCP site."""
        return Pose.from_pos_mat(*self.scene.tcp_pose())

    def commanded_tcp(self) -> Pose:
        """The TCP pose the last commanded configuration would put the TCP at (forward kinematics)."""
        return self.planner.fk(self.q_cmd)
