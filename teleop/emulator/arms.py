"""Emulated leader arms: a GELLO (8 × XL330) or an SO-101 leader (6 × STS3215) on an :class:`EmulatedBus`,
with the wiring faults users meet planted on request.

The physical arm is described by one :class:`~teleop.emulator.script.JointScript` per joint (the angle a
hand puts the joint at, rad, in the robot's joint convention) and by how each servo was mounted (horn offset
in ticks, direction), which calibration must discover.

Example::

    arm = ArmBuild.gello(seed=1)
    with arm.bus(scripts, clock) as bus:
        ...
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from mgdata.teleop.emulator.bus import Corruption, EmulatedBus
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.emulator.servo import STS3215, XL330, ControlTable, EmulatedServo

TICKS = 4096


@dataclass(frozen=True)
class ArmBuild:
    """How one physical leader was assembled, and which faults it has.

    Attributes:
        family: ``dynamixel`` or ``feetech``; ``table``: the servo model.
        ids: the id each joint's servo should have (joint order).
        mount: encoder ticks of each servo at joint angle 0 (any integer: the horn's position).
        direction: +1/-1 per servo.
        missing: joint indices whose servo does not answer (unplugged).
        swapped: a pair of joint indices whose servos carry each other's id.
        corruption: status-packet corruption on the bus.
    """

    family: str
    table: ControlTable
    ids: tuple[int, ...]
    mount: tuple[int, ...]
    direction: tuple[int, ...]
    missing: tuple[int, ...] = ()
    swapped: tuple[int, int] | None = None
    corruption: Corruption | None = field(default=None)

    @classmethod
    def gello(cls, seed: int = 0, gripper: bool = True) -> ArmBuild:
        """A GELLO: ids 1..7 (+ 8 for the trigger), horns at random positions, mixed directions."""
        n = 8 if gripper else 7
        rng = np.random.default_rng(seed)
        mount = tuple(int(v) for v in rng.integers(0, 40000, n))
        return cls("dynamixel", XL330, tuple(range(1, n + 1)), mount,
                   tuple(int(v) for v in rng.choice([-1, 1], n)))

    @classmethod
    def so101(cls, seed: int = 0) -> ArmBuild:
        """An SO-101 leader: ids 1..6, horns at random positions, mixed directions."""
        rng = np.random.default_rng(seed)
        return cls("feetech", STS3215, tuple(range(1, 7)), tuple(int(v) for v in rng.integers(0, TICKS, 6)),
                   tuple(int(v) for v in rng.choice([-1, 1], 6)))

    def near_wrap(self, joint: int, angle: float, ticks_below: int = 2) -> ArmBuild:
        """The same build with joint ``joint``'s servo reading ``ticks_below`` under the encoder wrap when the
        joint is at ``angle`` (so powering on there starts the counter at 4094, and moving crosses 4095/0)."""
        d = self.direction[joint]
        mount = list(self.mount)
        mount[joint] = int(np.rint(TICKS * 5 - ticks_below - d * angle * TICKS / (2 * np.pi)))
        return replace(self, mount=tuple(mount))

    def bus(self, scripts: Sequence[JointScript], clock: Callable[[], float], *, process: bool = True
            ) -> EmulatedBus:
        """The bus of this arm with each joint following its script, on a fresh pty (call ``start()`` or use
        it as a context manager)."""
        if len(scripts) != len(self.ids):
            raise ValueError(f"{len(self.ids)} joint scripts needed, got {len(scripts)}")
        ids = list(self.ids)
        if self.swapped is not None:
            a, b = self.swapped
            ids[a], ids[b] = ids[b], ids[a]
        servos = [EmulatedServo(ids[k], self.table, scripts[k], mount_ticks=self.mount[k],
                                direction=self.direction[k], clock=clock)
                  for k in range(len(ids)) if k not in self.missing]
        return EmulatedBus(self.family, servos, self.corruption, process=process)


class ManualClock:
    """A clock the test sets: the emulated arm is wherever its scripts say at :attr:`t` (shared with an
    emulator process forked after the clock was made)."""

    def __init__(self, t: float = 0.0) -> None:
        self._t = multiprocessing.Value("d", t, lock=False)

    @property
    def t(self) -> float:
        return float(self._t.value)

    @t.setter
    def t(self, value: float) -> None:
        self._t.value = value

    def __call__(self) -> float:
        return float(self._t.value)
