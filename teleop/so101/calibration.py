"""SO-101 leader calibration: LeRobot's per-motor format plus the leader→Panda mapping, in one JSON file.

``motors`` is exactly LeRobot's calibration format (``id``, ``drive_mode``, ``homing_offset``, ``range_min``,
``range_max`` per motor; the servo subtracts ``homing_offset`` on board, and the range is centred on 2047
ticks, so each joint reads 0 rad at the middle of its range, the convention of the SO-101 model). ``mapping``
holds the frame alignment (a quaternion taking the leader base frame to the Panda base frame) and the scale.

Unlike LeRobot's procedure, which centres each joint on wherever the operator held it and so breaks when
``wrist_roll`` is far from the middle (its range then crosses the encoder wrap, or its homing offset exceeds
the 11-bit field), :class:`SO101Calibrator` sweeps one joint at a time, follows the readings across the wrap,
and re-centres the homing offset on the middle of the range it measured. The joint the operator is asked to
sweep must be the servo that moves (a swapped id is one error naming both), and its first motion (towards
its positive end) gives ``drive_mode``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mgdata.atomic import write_text_atomic
from mgdata.errors import DeviceError, RecipeError
from mgdata.teleop.bus import Motor, ServoBus
from mgdata.teleop.motion_check import MotionWatch
from mgdata.teleop.ticks import RAD_PER_TICK, TICKS_PER_TURN, signed_diff

STS3215_MODEL = 777
MOTOR_NAMES = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")
HOMING_OFFSET, LOCK = 31, 55
HALF_TURN = 2047
MAX_OFFSET = 2047  # sign-magnitude, bit 11


def encode_offset(offset: int) -> int:
    """The register value of an STS homing offset (sign-magnitude, bit 11)."""
    return (abs(offset) & 0x7FF) | (0x800 if offset < 0 else 0)


@dataclass(frozen=True)
class MotorCalibration:
    """LeRobot's per-motor calibration record."""

    id: int
    drive_mode: int
    homing_offset: int
    range_min: int
    range_max: int


@dataclass(frozen=True)
class SO101Calibration:
    """One SO-101 leader's calibration file.

    Attributes:
        port, baudrate: where it was calibrated.
        motors: motor name -> :class:`MotorCalibration` (LeRobot's format), :data:`MOTOR_NAMES` order.
        align_quat: (w, x, y, z) rotation of the leader base frame into the Panda base frame.
        scale: Panda TCP metres per metre of leader end-effector motion.
    """

    port: str
    baudrate: int
    motors: dict[str, MotorCalibration]
    align_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    scale: float = 1.5

    @property
    def bus_motors(self) -> list[Motor]:
        return [Motor(n, self.motors[n].id, STS3215_MODEL) for n in MOTOR_NAMES]

    def joints_q(self, ticks: np.ndarray) -> np.ndarray:
        """The five arm joint angles (rad, model convention) from a reading of :attr:`bus_motors`."""
        out = np.empty(5)
        for k, name in enumerate(MOTOR_NAMES[:5]):
            m = self.motors[name]
            mid = (m.range_min + m.range_max) / 2.0
            sign = -1.0 if m.drive_mode else 1.0
            out[k] = sign * float(signed_diff(int(ticks[k]), int(np.rint(mid)))) * RAD_PER_TICK
        return out

    def gripper_open(self, ticks: np.ndarray) -> float:
        """Trigger opening in [0, 1] (0 at the closed end of the swept range)."""
        m = self.motors["gripper"]
        span = max(1, m.range_max - m.range_min)
        frac = float(signed_diff(int(ticks[5]), m.range_min)) / span
        frac = frac if not m.drive_mode else 1.0 - frac
        return float(np.clip(frac, 0.0, 1.0))

    def apply(self, bus: ServoBus) -> None:
        """Make sure every servo subtracts this file's homing offset (LeRobot does the same on connect)."""
        for m in bus.motors:
            want = encode_offset(self.motors[m.name].homing_offset)
            if bus.read(m, HOMING_OFFSET, 2) != want:
                bus.write1(m, LOCK, 0)
                bus.write2(m, HOMING_OFFSET, want)
                bus.write1(m, LOCK, 1)

    # -- file -------------------------------------------------------------------------------------------
    def save(self, path: Path) -> None:
        d = {"arm": "so101", "port": self.port, "baudrate": self.baudrate,
             "motors": {n: vars(m) for n, m in self.motors.items()},
             "mapping": {"align_quat": list(self.align_quat), "scale": self.scale}}
        write_text_atomic(Path(path), json.dumps(d, indent=2) + "\n")

    @classmethod
    def load(cls, path: Path) -> SO101Calibration:
        path = Path(path)
        if not path.is_file():
            raise RecipeError(f"SO-101 calibration file {path} does not exist; run "
                              "`mgdata teleop calibrate --arm so101 --port PORT --out FILE` first")
        return cls.from_json(path.read_text(encoding="utf-8"), str(path))

    @classmethod
    def from_json(cls, text: str, source: str = "calibration") -> SO101Calibration:
        """Parse a calibration file's text; ``source`` names it in errors."""
        try:
            d = json.loads(text)
            if d.get("arm") != "so101":
                raise ValueError("not an SO-101 calibration (arm is not 'so101')")
            motors = {n: MotorCalibration(**{k: int(v) for k, v in d["motors"][n].items()})
                      for n in MOTOR_NAMES}
            mapping = d["mapping"]
            quat = tuple(float(v) for v in mapping["align_quat"])
            if len(quat) != 4 or abs(np.linalg.norm(quat) - 1.0) > 1e-6:
                raise ValueError("mapping.align_quat must be a unit quaternion (w, x, y, z)")
            if not float(mapping["scale"]) > 0:
                raise ValueError("mapping.scale must be > 0")
            return cls(str(d["port"]), int(d["baudrate"]), motors, quat, float(mapping["scale"]))  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError, json.JSONDecodeError) as err:
            raise RecipeError(f"{source}: not a valid SO-101 calibration file: {err}") from None


class SO101Calibrator:
    """The calibration procedure, one method per operator step.

    Example::

        c = SO101Calibrator(bus)
        c.capture_middle()                     # arm held at the middle of every joint's range
        for k in range(6):
            watch = c.watch(bus.read_positions())
            ...  # operator moves joint k towards its positive end first, then through its whole range
            c.finish_joint(k, watch)
        cal = c.result(scale=1.5)
    """

    MIN_SWEEP_TICKS = 300
    WRAP_MARGIN = 16  # ticks a sweep must stay short of a full turn

    def __init__(self, bus: ServoBus) -> None:
        self.bus = bus
        self._offsets: list[int] = [0] * 6
        self._records: dict[str, MotorCalibration] = {}

    def _write_offset(self, m: Motor, offset: int) -> None:
        self.bus.write1(m, LOCK, 0)
        self.bus.write2(m, HOMING_OFFSET, encode_offset(offset))
        self.bus.write1(m, LOCK, 1)

    def capture_middle(self) -> None:
        """Centre every servo on its current position (reads 2047 there), as LeRobot's first step does."""
        for m in self.bus.motors:
            self._write_offset(m, 0)
        raw = self.bus.read_positions()
        for k, m in enumerate(self.bus.motors):
            self._offsets[k] = int(np.clip(signed_diff(int(raw[k]), HALF_TURN), -MAX_OFFSET, MAX_OFFSET))
            self._write_offset(m, self._offsets[k])

    def watch(self, ticks: np.ndarray) -> MotionWatch:
        return MotionWatch(np.asarray(ticks))

    def finish_joint(self, k: int, watch: MotionWatch) -> MotorCalibration:
        """Record joint ``k``'s range from the sweep, re-centring its homing offset on the range's middle."""
        m = self.bus.motors[k]
        sign = watch.moved(self.bus.motors, k, self.MIN_SWEEP_TICKS, self.bus.port)
        start = int(watch.start[k])
        lo, hi = start + int(watch.lo[k]), start + int(watch.hi[k])
        if hi - lo > TICKS_PER_TURN - self.WRAP_MARGIN:
            raise DeviceError(f"calibration: {m.name} (id {m.id}) on {self.bus.port} swept {hi - lo} ticks, "
                              "about "
                              "a full turn; sweep it only between its mechanical stops")
        old = self._offsets[k]
        offset = old + int(np.rint((lo + hi) / 2.0)) - HALF_TURN
        # the same readings modulo a turn, with the offset in [-2048, 2048)
        offset = (offset + TICKS_PER_TURN // 2) % TICKS_PER_TURN - TICKS_PER_TURN // 2
        offset = int(np.clip(offset, -MAX_OFFSET, MAX_OFFSET))  # -2048 does not fit: one tick off centre
        lo, hi = lo - (offset - old), hi - (offset - old)  # readings with the new offset
        turns = int(np.rint(((lo + hi) / 2.0 - HALF_TURN) / TICKS_PER_TURN))
        lo, hi = lo - turns * TICKS_PER_TURN, hi - turns * TICKS_PER_TURN
        self._offsets[k] = offset
        self._write_offset(m, offset)
        rec = MotorCalibration(m.id, 0 if sign > 0 else 1, offset, lo, hi)
        self._records[m.name] = rec
        return rec

    def result(self, scale: float, align_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
               ) -> SO101Calibration:
        missing = [n for n in MOTOR_NAMES if n not in self._records]
        if missing:
            raise DeviceError(f"calibration incomplete: sweep {', '.join(missing)} first")
        return SO101Calibration(self.bus.port, self.bus.baudrate, dict(self._records), align_quat, scale)


def so101_motors() -> list[Motor]:
    """The motors of an uncalibrated SO-101 leader: ids 1..6 in :data:`MOTOR_NAMES` order."""
    return [Motor(n, k + 1, STS3215_MODEL) for k, n in enumerate(MOTOR_NAMES)]
