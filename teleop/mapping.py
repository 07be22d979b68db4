"""From leader readings to Panda actions: the per-arm mapping, stateful per episode and deterministic given
the readings and the operator events (so a recorded leader stream re-simulates exactly).

* :class:`GelloMapper`: the seven calibrated joint angles mirrored 1:1 (each joint's step limited to
  ``[leader] max_joint_step``, so a leader far from the robot at the start is followed smoothly); the gripper
  closes past ``gripper_threshold`` of the trigger's travel, or toggles on a hotkey without a trigger.
* :class:`SO101Mapper`: the five SO-101 joints → forward kinematics → :class:`~teleop.retarget.Retargeter`;
  the gripper closes when the leader's jaw is closed past the threshold.

Example::

    mapper = mapper_for("gello", calibration_text, load_teleop_config())
    mapper.reset(scene.arm_q())
    q, grip = mapper.command(ticks, StepEvents())
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from mgdata.errors import RecipeError
from mgdata.teleop.bus import Motor
from mgdata.teleop.config import TeleopConfig
from mgdata.teleop.gello import GelloCalibration
from mgdata.teleop.retarget import Retargeter, RetargetStep
from mgdata.teleop.so101.calibration import SO101Calibration

ARMS = ("gello", "so101")


@dataclass(frozen=True)
class StepEvents:
    """Operator events that arrived before a control step."""

    clutch: bool = False
    grip_toggle: bool = False


class Mapper(Protocol):
    arm: str
    motors: list[Motor]

    @property
    def engaged(self) -> bool:
        """The robot follows the leader (``False`` while an SO-101's clutch is out)."""
        ...

    def reset(self, q0: np.ndarray) -> None: ...

    def command(self, ticks: np.ndarray, events: StepEvents) -> tuple[np.ndarray, float]: ...


class GelloMapper:
    """GELLO joints → Panda joints 1:1 (see the module docstring)."""

    arm = "gello"
    engaged = True  # no clutch

    def __init__(self, cal: GelloCalibration, config: TeleopConfig) -> None:
        self.cal, self.config = cal, config.leader
        self.motors = cal.motors
        self.q = np.zeros(7)
        self.grip = 0.0

    def reset(self, q0: np.ndarray) -> None:
        self.q = np.asarray(q0, dtype=np.float64).copy()
        self.grip = 0.0

    def command(self, ticks: np.ndarray, events: StepEvents) -> tuple[np.ndarray, float]:
        dq = self.cal.joints_q(ticks) - self.q
        worst = float(np.max(np.abs(dq)))
        if worst > self.config.max_joint_step:
            dq *= self.config.max_joint_step / worst
        self.q = self.q + dq
        travel = self.cal.gripper(ticks)
        if travel is None:
            if events.grip_toggle:
                self.grip = 1.0 - self.grip
        else:
            self.grip = 1.0 if travel > self.config.gripper_threshold else 0.0
        return self.q.copy(), self.grip


class SO101Mapper:
    """SO-101 end effector → Panda TCP → IK (see the module docstring).

    Attributes:
        last: the latest :class:`RetargetStep` (target, clamp, IK status) for the operator view.
    """

    arm = "so101"

    def __init__(self, cal: SO101Calibration, config: TeleopConfig) -> None:
        self.cal, self.config = cal, config
        self.motors = cal.bus_motors
        self.retarget = Retargeter(cal, config.retarget)
        self.last: RetargetStep | None = None

    @property
    def engaged(self) -> bool:
        return self.retarget.engaged

    def reset(self, q0: np.ndarray) -> None:
        self.retarget = Retargeter(self.cal, self.config.retarget, q0=q0)
        self.last = None

    def command(self, ticks: np.ndarray, events: StepEvents) -> tuple[np.ndarray, float]:
        self.last = self.retarget.step(self.cal.joints_q(ticks), clutch=events.clutch)
        closed = 1.0 - self.cal.gripper_open(ticks)
        return self.last.q, 1.0 if closed > self.config.leader.gripper_threshold else 0.0


def mapper_for(arm: str, calibration: str, config: TeleopConfig, source: str = "calibration") -> Mapper:
    """The mapper of ``arm`` from a calibration file's text."""
    if arm == "gello":
        return GelloMapper(GelloCalibration.from_json(calibration, source), config)
    if arm == "so101":
        return SO101Mapper(SO101Calibration.from_json(calibration, source), config)
    raise RecipeError(f"unknown arm {arm!r}; expected one of {', '.join(ARMS)}")
