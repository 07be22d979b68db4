"""Encoder arithmetic shared by the drivers: 4096 ticks per turn, wrap-free differences and angles."""

from __future__ import annotations

import numpy as np

TICKS_PER_TURN = 4096
RAD_PER_TICK = 2.0 * np.pi / TICKS_PER_TURN


def signed_diff(a: np.ndarray | int, b: np.ndarray | int) -> np.ndarray:
    """``a - b`` in ticks, taken modulo one turn into ``[-2048, 2048)``: the short way round."""
    return (np.asarray(a, dtype=np.int64) - b + TICKS_PER_TURN // 2) % TICKS_PER_TURN - TICKS_PER_TURN // 2


def to_window(q: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Angles ``q`` (rad) moved by whole turns into ``[centre - pi, centre + pi)``.

    A joint whose travel is shorter than a turn has exactly one reading in that window, so the reading does
    not depend on which turn the encoder's counter started in at power-on.
    """
    return centre + np.mod(q - centre + np.pi, 2.0 * np.pi) - np.pi


class Unwrapper:
    """Follows readings of a wrapping encoder continuously (consecutive readings less than half a turn apart).

    Example::

        u = Unwrapper(np.array([4090]))
        u.update(np.array([3]))   # array([4099])
    """

    def __init__(self, first: np.ndarray) -> None:
        self.value = np.asarray(first, dtype=np.int64).copy()
        self._last = self.value % TICKS_PER_TURN

    def update(self, reading: np.ndarray) -> np.ndarray:
        reading = np.asarray(reading, dtype=np.int64) % TICKS_PER_TURN
        self.value = self.value + signed_diff(reading, self._last)
        self._last = reading
        return self.value.copy()
