"""Scripted physical joint motion: what a person's hand does to one leader joint, as angle over time."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


class JointScript:
    """A joint angle (rad) that moves piecewise-linearly through ``(time s, angle rad)`` knots and holds the
    last angle afterwards.

    Example::

        wave = JointScript([0.0, 1.0, 2.0], [0.0, 0.5, 0.0])
        wave(0.5)   # 0.25
    """

    def __init__(self, times: Sequence[float], angles: Sequence[float]) -> None:
        t = np.asarray(times, dtype=np.float64)
        a = np.asarray(angles, dtype=np.float64)
        if t.ndim != 1 or t.shape != a.shape or len(t) == 0:
            raise ValueError("times and angles must be 1-D sequences of the same non-zero length")
        if np.any(np.diff(t) < 0):
            raise ValueError("script times must not decrease")
        self.times, self.angles = t, a

    @classmethod
    def constant(cls, angle: float) -> JointScript:
        return cls([0.0], [angle])

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def __call__(self, t: float) -> float:
        return float(np.interp(t, self.times, self.angles))
