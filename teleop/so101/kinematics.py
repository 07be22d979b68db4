"""Forward kinematics of the SO-101 from its real model (``so101_kinematics.xml``, see ``NOTICE``).

Joint angles are in the model's "new calibration" convention: each joint's zero is the middle of its range,
which is what a LeRobot-style calibration (range centred on 2047 ticks) reads as 0.

Example::

    fk = SO101Kinematics()
    pos, rot = fk.ee(np.zeros(5))    # gripper frame in the arm's base frame: m, 3×3
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import mujoco
import numpy as np

MODEL_XML = Path(str(files("mgdata.teleop.so101") / "so101_kinematics.xml"))
ARM_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")
EE_SITE = "gripperframe"


class SO101Kinematics:
    """The gripper frame's pose for five arm joint angles (rad)."""

    def __init__(self) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(MODEL_XML))
        self.data = mujoco.MjData(self.model)
        self._site = self.model.site(EE_SITE).id
        self._qadr = np.array([self.model.joint(n).qposadr[0] for n in ARM_JOINTS])
        self.lower = np.array([self.model.joint(n).range[0] for n in ARM_JOINTS])
        self.upper = np.array([self.model.joint(n).range[1] for n in ARM_JOINTS])

    def ee(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position (m, (3,)) and rotation ((3, 3)) of the gripper frame in the base frame."""
        self.data.qpos[self._qadr] = q
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.site_xpos[self._site].copy(), self.data.site_xmat[self._site].reshape(3, 3).copy()
