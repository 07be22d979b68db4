"""Joint identification during calibration: which servo moved when the operator moved one joint.

A calibration step asks the operator to move one named joint (in its positive direction, then back); a
:class:`MotionWatch` is fed every reading meanwhile and afterwards says which servo moved most, how far and in
which direction. A servo other than the expected one is the "swapped ids" wiring fault, reported by name.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mgdata.errors import DeviceError
from mgdata.teleop.bus import Motor
from mgdata.teleop.ticks import Unwrapper


class MotionWatch:
    """Excursion of every servo from its reading when the watch started (ticks, unwrapped)."""

    def __init__(self, first: np.ndarray) -> None:
        self._u = Unwrapper(first)
        self.start = self._u.value.copy()
        self.lo = np.zeros(len(self.start), dtype=np.int64)
        self.hi = np.zeros(len(self.start), dtype=np.int64)
        self.first_sign = np.zeros(len(self.start), dtype=np.int64)
        self.threshold = 100  # ticks past which a servo's first direction of motion is recorded

    def update(self, reading: np.ndarray) -> None:
        d = self._u.update(reading) - self.start
        self.lo = np.minimum(self.lo, d)
        self.hi = np.maximum(self.hi, d)
        fresh = (self.first_sign == 0) & (np.abs(d) > self.threshold)
        self.first_sign[fresh] = np.sign(d[fresh])

    def moved(self, motors: Sequence[Motor], expected: int, min_ticks: int, port: str) -> int:
        """The direction (+1/-1, in ticks) in which the expected servo first moved; errors if another servo
        moved most or the expected one moved less than ``min_ticks``."""
        span = np.maximum(self.hi, -self.lo)
        names = [f"{m.name} (id {m.id})" for m in motors]
        k = int(np.argmax(span))
        if span[k] < min_ticks:
            raise DeviceError(f"calibration: no servo on {port} moved by {min_ticks} ticks while "
                              f"{names[expected]} "
                              "was to be moved; move the joint further (about 30 degrees) and repeat")
        if k != expected:
            raise DeviceError(f"calibration: moving {names[expected]} moved the servo registered as "
                              f"{names[k]} on {port} ({span[k]} ticks; {names[expected]}'s servo moved "
                              f"{span[expected]}): the two servos' ids look swapped; fix the ids (or the "
                              "cabling) and calibrate again")
        return int(self.first_sign[k])
