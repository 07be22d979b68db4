"""JointController: the 8-D joint-native action interface at 20 Hz over 500 Hz physics.

``action`` = 7 commanded arm joint targets (rad) + gripper command (1.0 close, 0.0 open; values in between
interpolate the actuator control). The arm's position servos (Menagerie gains) track the targets; one
:meth:`step` holds the action for one control period (``scene.physics.substeps`` physics steps) and then runs
the scene's per-control-step bookkeeping (dust wiping). ``state`` = 7 measured arm joints + gripper opening
(m, the sum of the two finger joints), float32.

Example::

    ctl = JointController(scene)
    ctl.apply(np.array([*HOME_Q, 1.0]))   # close the gripper at home
    ctl.step()
    ctl.state()
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import numpy as np

from mgdata.errors import MgdataError, SimulationError
from mgdata.sim import robot
from mgdata.sim.scene import Scene


class SubstepWatcher(Protocol):
    """Something that sees every physics step of a control period (e.g. the gate's rest check)."""

    def reset(self) -> None:
        """A control period begins."""

    def observe(self, data: mujoco.MjData) -> None:
        """One physics step was taken (``data.cvel``/``xpos`` are those of the state it started from)."""


class JointController:
    """Maps 8-D actions to the Panda's actuators and advances the scene one control period per step."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        model = scene.model
        self._act = robot.arm_actuator_ids(model)
        self._lo = model.actuator_ctrlrange[self._act[:7], 0].copy()
        self._hi = model.actuator_ctrlrange[self._act[:7], 1].copy()
        self._substeps = scene.physics.substeps
        self._gripper = scene.gripper
        self.last_action = np.zeros(8, dtype=np.float32)
        self._watchers: list[SubstepWatcher] = []

    def watch(self, watcher: SubstepWatcher) -> None:
        """Show ``watcher`` every physics step of every later control period (reset at each period's
        start, observed after each ``mj_step``)."""
        self._watchers.append(watcher)

    def apply(self, action: np.ndarray) -> None:
        """Set the actuator controls for ``action`` (8,): arm targets are clipped to the joint ranges.

        Raises:
            MgdataError: the action is not 8 finite numbers.
        """
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (8,) or not np.all(np.isfinite(a)):
            raise MgdataError(f"action must be 8 finite numbers (7 joint targets + gripper), got {action!r}")
        ctrl = self.scene.data.ctrl
        ctrl[self._act[:7]] = np.clip(a[:7], self._lo, self._hi)
        ctrl[self._act[7]] = self._gripper.ctrl(a[7])
        self.last_action = a.astype(np.float32)

    def step(self) -> None:
        """Advance one control period with the current controls.

        Raises:
            SimulationError: the physics diverged (MuJoCo then silently resets the state, so this is fatal).

        Ends with ``mj_forward`` so positions and contacts describe the new state (as after
        ``Scene.restore``); that call does not change the trajectory.
        """
        m, d = self.scene.model, self.scene.data
        diverged = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number
        watchers = self._watchers
        for w in watchers:
            w.reset()
        for _ in range(self._substeps):
            mujoco.mj_step(m, d)
            for w in watchers:
                w.observe(d)
        if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number != diverged:
            # MuJoCo has already reset the state to qpos0; continuing would record a teleported world.
            raise SimulationError(f"the physics diverged in the control step ending at t = {d.time:.3f} s "
                                  "(NaN/Inf accelerations); the episode must be discarded")
        self.scene.after_control_step()
        mujoco.mj_forward(m, d)

    def state(self) -> np.ndarray:
        """Measured arm joints (7) + gripper opening (m), float32 (8,)."""
        out = np.empty(8, dtype=np.float32)
        out[:7] = self.scene.arm_q()
        out[7] = self.scene.gripper_opening()
        return out
