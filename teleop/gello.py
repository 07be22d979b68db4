"""GELLO leader for the Panda: seven Dynamixel joints mirrored 1:1, plus an optional gripper-trigger servo.

Calibration (:class:`GelloCalibrator`, driven by ``mgdata teleop calibrate --arm gello``) measures everything
about one physical device and writes it to a JSON file; nothing device-specific lives in source:

1. the operator holds the leader in a known Panda pose (default ``HOME_Q``), trigger released;
2. moves each joint in turn in the Panda's positive direction and back: this checks that the servo that moves
   is the one with that joint's id (a swapped pair is one error naming both) and measures its sign;
3. squeezes the trigger (if the device has one).

A reading maps ticks to joint angles with :meth:`GelloCalibration.joints_q`: ``sign * (ticks - offset)``, then
moved by whole turns into the window centred on the Panda joint's range. Every Panda joint travels less than
a turn, so this reading does not depend on the turn the servo's multi-turn counter started in at power-on.

Example::

    cal = GelloCalibration.load(path)
    q, grip = cal.joints_q(ticks), cal.gripper(ticks)
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from mgdata.atomic import write_text_atomic
from mgdata.errors import DeviceError, RecipeError
from mgdata.motion.ik import kinematic_arm_model
from mgdata.teleop.bus import Motor, ServoBus
from mgdata.teleop.motion_check import MotionWatch
from mgdata.teleop.ticks import RAD_PER_TICK, signed_diff, to_window

XL330_MODEL = 1200
ARM_IDS = (1, 2, 3, 4, 5, 6, 7)
GRIPPER_ID = 8


def panda_joint_centres() -> np.ndarray:
    """Centres of the Panda's joint ranges (rad): the reading windows."""
    r = kinematic_arm_model().jnt_range
    return (r[:, 0] + r[:, 1]) / 2.0


@dataclass(frozen=True)
class GelloJoint:
    """One calibrated joint: servo id, sign (+1: servo ticks grow with the Panda joint angle), offset (ticks
    the servo reads at joint angle 0, modulo whole turns)."""

    id: int
    sign: int
    offset: int


@dataclass(frozen=True)
class GelloCalibration:
    """A GELLO device's calibration (one JSON file per device).

    Attributes:
        port, baudrate: where the device was calibrated (the session may override the port).
        joints: the seven arm joints, Panda order.
        gripper_id, gripper_open, gripper_closed: the trigger servo and its ticks released/squeezed;
            ``gripper_id`` is ``None`` on a device without a trigger (a hotkey closes the gripper instead).
        pose: the known Panda pose (rad) the offsets were measured in.
    """

    port: str
    baudrate: int
    joints: tuple[GelloJoint, ...]
    gripper_id: int | None
    gripper_open: int
    gripper_closed: int
    pose: tuple[float, ...]

    @property
    def motors(self) -> list[Motor]:
        motors = [Motor(f"joint{k + 1}", j.id, XL330_MODEL) for k, j in enumerate(self.joints)]
        if self.gripper_id is not None:
            motors.append(Motor("gripper", self.gripper_id, XL330_MODEL))
        return motors

    def joints_q(self, ticks: np.ndarray) -> np.ndarray:
        """Panda joint angles (rad, (7,)) from a reading of :attr:`motors` (ticks)."""
        t = np.asarray(ticks[:7], dtype=np.float64)
        sign = np.array([j.sign for j in self.joints], dtype=np.float64)
        offset = np.array([j.offset for j in self.joints], dtype=np.float64)
        return to_window(sign * (t - offset) * RAD_PER_TICK, panda_joint_centres())

    def gripper(self, ticks: np.ndarray) -> float | None:
        """Trigger travel in [0, 1] (0 released, 1 squeezed), ``None`` without a trigger servo."""
        if self.gripper_id is None:
            return None
        travel = float(signed_diff(self.gripper_closed, self.gripper_open))
        frac = float(signed_diff(int(ticks[7]), self.gripper_open)) / travel
        return float(np.clip(frac, 0.0, 1.0))

    # -- file -------------------------------------------------------------------------------------------
    def save(self, path: Path) -> None:
        d = asdict(self)
        d = {"arm": "gello", **d, "joints": [asdict(j) for j in self.joints], "pose": list(self.pose)}
        write_text_atomic(Path(path), json.dumps(d, indent=2) + "\n")

    @classmethod
    def load(cls, path: Path) -> GelloCalibration:
        path = Path(path)
        if not path.is_file():
            raise RecipeError(f"GELLO calibration file {path} does not exist; run "
                              "`mgdata teleop calibrate --arm gello --port PORT --out FILE` first")
        return cls.from_json(path.read_text(encoding="utf-8"), str(path))

    @classmethod
    def from_json(cls, text: str, source: str = "calibration") -> GelloCalibration:
        """Parse a calibration file's text; ``source`` names it in errors."""
        try:
            d = json.loads(text)
            if d.pop("arm", None) != "gello":
                raise ValueError("not a GELLO calibration (arm is not 'gello')")
            joints = tuple(GelloJoint(int(j["id"]), int(j["sign"]), int(j["offset"]))
                           for j in d.pop("joints"))
            if len(joints) != 7 or any(j.sign not in (1, -1) for j in joints):
                raise ValueError("expected 7 joints with sign +1 or -1")
            return cls(port=str(d["port"]), baudrate=int(d["baudrate"]), joints=joints,
                       gripper_id=None if d["gripper_id"] is None else int(d["gripper_id"]),
                       gripper_open=int(d["gripper_open"]), gripper_closed=int(d["gripper_closed"]),
                       pose=tuple(float(v) for v in d["pose"]))
        except (KeyError, TypeError, ValueError, json.JSONDecodeError) as err:
            raise RecipeError(f"{source}: not a valid GELLO calibration file: {err}") from None


class GelloCalibrator:
    """The calibration procedure, one method per operator step (the CLI prompts between them).

    Example::

        c = GelloCalibrator(bus, pose=HOME_Q)
        c.capture_pose(bus.read_positions())
        for k in range(7):
            watch = c.watch(bus.read_positions())
            ...  # operator moves joint k+1; feed watch.update(bus.read_positions()) meanwhile
            c.finish_joint(k, watch)
        c.capture_gripper_closed(bus.read_positions())
        cal = c.result()
    """

    MIN_MOTION_TICKS = 200  # about 18 degrees: a joint the operator moved, not a servo that was bumped

    def __init__(self, bus: ServoBus, pose: Sequence[float], has_gripper: bool) -> None:
        if len(pose) != 7:
            raise RecipeError(f"the known pose needs 7 joint angles, got {len(pose)}")
        self.bus, self.pose, self.has_gripper = bus, tuple(float(v) for v in pose), has_gripper
        self._at_pose: np.ndarray | None = None
        self._signs: list[int | None] = [None] * 7
        self._closed: int | None = None

    def capture_pose(self, ticks: np.ndarray) -> None:
        self._at_pose = np.asarray(ticks, dtype=np.int64).copy()

    def watch(self, ticks: np.ndarray) -> MotionWatch:
        return MotionWatch(np.asarray(ticks)[:7])

    def finish_joint(self, k: int, watch: MotionWatch) -> int:
        """Record joint ``k``'s sign from what moved; raises DeviceError on swapped ids or no motion."""
        self._signs[k] = watch.moved(self.bus.motors[:7], k, self.MIN_MOTION_TICKS, self.bus.port)
        return self._signs[k]

    def capture_gripper_closed(self, ticks: np.ndarray) -> None:
        self._closed = int(ticks[7])

    def result(self) -> GelloCalibration:
        if self._at_pose is None or None in self._signs:
            raise DeviceError("calibration incomplete: capture the pose and move every joint first")
        joints = []
        for k, m in enumerate(self.bus.motors[:7]):
            sign = int(self._signs[k])  # type: ignore[arg-type]
            offset = int(np.rint(self._at_pose[k] - sign * self.pose[k] / RAD_PER_TICK))
            joints.append(GelloJoint(m.id, sign, offset))
        gripper_open = int(self._at_pose[7]) if self.has_gripper else 0
        closed = self._closed if self._closed is not None else gripper_open
        if self.has_gripper and abs(int(signed_diff(closed, gripper_open))) < 50:
            raise DeviceError(f"calibration: the trigger servo (id {self.bus.motors[7].id}) on "
                              f"{self.bus.port} "
                              "moved less than 50 ticks between released and squeezed")
        return GelloCalibration(port=self.bus.port, baudrate=self.bus.baudrate, joints=tuple(joints),
                                gripper_id=self.bus.motors[7].id if self.has_gripper else None,
                                gripper_open=gripper_open, gripper_closed=closed, pose=self.pose)


def gello_motors(has_gripper: bool) -> list[Motor]:
    """The motors of an uncalibrated GELLO: ids 1..7 for the joints, 8 for the trigger."""
    motors = [Motor(f"joint{k}", k, XL330_MODEL) for k in ARM_IDS]
    return motors + ([Motor("gripper", GRIPPER_ID, XL330_MODEL)] if has_gripper else [])
