"""One emulated servo: a control table, torque enable, and a shaft that a scripted hand moves.

The shaft angle follows a :class:`~teleop.emulator.script.JointScript` (radians of the physical joint the
servo is mounted on, over time) while torque is off, as a leader arm's servo does when a person moves it;
with torque on the servo holds the shaft and slews it towards the goal position instead. The encoder reading
is the shaft's absolute angle in ticks (4096 per turn) plus a mounting offset. What the host reads as present
position depends on the family:

* Dynamixel X-series (multi-turn counting in position mode): at power-on the counter starts inside one turn
  (``raw mod 4096``) and then counts continuously, so a joint powered on near the wrap reads near 0 or 4095
  and crosses it as it moves;
* Feetech STS: ``(raw - homing_offset) mod 4096``, 12 bits, with the homing offset in EEPROM (sign-magnitude,
  bit 11).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

from mgdata.teleop.emulator.script import JointScript

TICKS_PER_TURN = 4096


@dataclass(frozen=True)
class ControlTable:
    """Addresses of one servo family's control table (byte offsets, sizes in bytes).

    Attributes:
        model_number: address of the 2-byte model number; ``model``: its value.
        id: the 1-byte id; ``torque_enable``: 1 byte; ``goal_position``/``present_position``: their address
        and size; ``homing_offset``: the EEPROM offset subtracted from the encoder (``None``: not emulated);
        ``size``: bytes in the table.
    """

    family: str
    model: int
    model_number: int
    id: int
    torque_enable: int
    goal_position: tuple[int, int]
    present_position: tuple[int, int]
    homing_offset: tuple[int, int] | None
    size: int


XL330 = ControlTable("dynamixel", model=1200, model_number=0, id=7, torque_enable=64, goal_position=(116, 4),
                     present_position=(132, 4), homing_offset=None, size=256)
"""Dynamixel XL330-M288 (Protocol 2.0), GELLO's servo."""

STS3215 = ControlTable("feetech", model=777, model_number=3, id=5, torque_enable=40, goal_position=(42, 2),
                       present_position=(56, 2), homing_offset=(31, 2), size=256)
"""Feetech STS3215 (SCS/STS protocol, little-endian), the SO-101's servo."""


def _sign_magnitude(value: int, sign_bit: int) -> int:
    return (abs(value) & ((1 << sign_bit) - 1)) | ((1 << sign_bit) if value < 0 else 0)


def _from_sign_magnitude(raw: int, sign_bit: int) -> int:
    magnitude = raw & ((1 << sign_bit) - 1)
    return -magnitude if raw & (1 << sign_bit) else magnitude


class EmulatedServo:
    """One servo on an emulated bus.

    Args:
        servo_id: its bus id (a planted "swapped ids" fault gives two servos each other's id).
        table: the family's control table layout.
        script: the physical joint angle (rad) over time while a hand moves it.
        mount_ticks: encoder ticks at joint angle 0 (how the horn was mounted), any integer.
        direction: +1 or -1, how the servo is mounted relative to the joint's positive direction.
        clock: seconds since power-on (shared by every servo on the bus).
    """

    def __init__(self, servo_id: int, table: ControlTable, script: JointScript, *, mount_ticks: int = 2048,
                 direction: int = 1, clock: Callable[[], float]) -> None:
        self.table = table
        self.script = script
        self.mount_ticks = mount_ticks
        self.direction = direction
        self.clock = clock
        self.mem = bytearray(table.size)
        self._lock = threading.Lock()
        self._write(table.model_number, table.model, 2)
        self._write(table.id, servo_id, 1)
        self._held: float | None = None  # shaft ticks while torque holds it
        self._turn_base = math.floor(self._raw() / TICKS_PER_TURN) * TICKS_PER_TURN  # power-on turn count

    @property
    def id(self) -> int:
        return self.mem[self.table.id]

    @property
    def torque(self) -> bool:
        return bool(self.mem[self.table.torque_enable])

    def _raw(self) -> float:
        """The shaft's absolute encoder position in ticks (not wrapped)."""
        if self._held is not None:
            return self._held
        angle = self.script(self.clock())
        return self.mount_ticks + self.direction * angle * TICKS_PER_TURN / (2 * math.pi)

    def _write(self, address: int, value: int, size: int) -> None:
        self.mem[address:address + size] = (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")

    def _read_int(self, address: int, size: int) -> int:
        return int.from_bytes(self.mem[address:address + size], "little")

    def _present_base(self) -> int:
        """Encoder ticks that read as present position 0 (power-on turn or homing offset)."""
        if self.table.family == "dynamixel":
            return self._turn_base
        if self.table.homing_offset is None:
            return 0
        return _from_sign_magnitude(self._read_int(*self.table.homing_offset), 11)

    def present_position(self) -> int:
        """The value the host reads at the present-position address now."""
        value = round(self._raw()) - self._present_base()
        return value if self.table.family == "dynamixel" else value % TICKS_PER_TURN

    def read(self, address: int, length: int) -> bytes:
        """Bytes ``address .. address + length`` of the control table, present position refreshed."""
        if address < 0 or address + length > self.table.size:
            raise IndexError(f"read of {length} bytes at {address} outside the control table")
        with self._lock:
            addr, size = self.table.present_position
            self._write(addr, self.present_position(), size)
            return bytes(self.mem[address:address + length])

    def write(self, address: int, data: bytes) -> None:
        """Write control-table bytes; torque enable and goal position act on the shaft."""
        if address < 0 or address + len(data) > self.table.size:
            raise IndexError(f"write of {len(data)} bytes at {address} outside the control table")
        with self._lock:
            was_on = self.torque
            self.mem[address:address + len(data)] = data
            if self.torque and not was_on:
                self._held = float(round(self._raw()))  # the motor now holds the shaft where it is
            elif not self.torque:
                self._held = None
            addr, size = self.table.goal_position
            if self.torque and address <= addr < address + len(data):
                goal = int.from_bytes(self.mem[addr:addr + size], "little", signed=True)
                self._held = float(goal + self._present_base())


def encode_homing_offset(offset: int) -> int:
    """An STS homing offset as stored (sign-magnitude, bit 11); ``|offset|`` must be ≤ 2047."""
    if abs(offset) > 2047:
        raise ValueError(f"homing offset {offset} does not fit sign-magnitude bit 11 (|offset| <= 2047)")
    return _sign_magnitude(offset, 11)
