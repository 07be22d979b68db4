"""A scripted operator: the hand motions and button presses of a calibration, against an emulated arm.

Used by the tests and the benchmark to calibrate emulated leaders through the real procedure (the same
calibrator methods the CLI calls between its prompts), on a :class:`~teleop.emulator.arms.ManualClock`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mgdata.teleop.bus import ServoBus
from mgdata.teleop.emulator.arms import ManualClock
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.gello import GelloCalibration, GelloCalibrator
from mgdata.teleop.so101.calibration import SO101Calibration, SO101Calibrator

MOVE = 0.5  # rad a joint is moved to identify it


def gello_calibration_scripts(pose: Sequence[float], trigger: bool = True, then: Sequence[JointScript] = ()
                              ) -> list[JointScript]:
    """Joint scripts for a GELLO calibration: hold ``pose`` until t = 1 s, move joint k by +0.5 rad and back
    during [1 + k, 2 + k] s, squeeze the trigger (0.6 rad) at t = 9-10 s, release at 11 s."""
    scripts = []
    for k in range(7):
        scripts.append(JointScript([0, 1 + k, 1.5 + k, 2 + k], [pose[k], pose[k], pose[k] + MOVE, pose[k]]))
    if trigger:
        scripts.append(JointScript([0, 9, 10, 10.5, 11], [0, 0, 0.6, 0.6, 0]))
    return scripts


def calibrate_gello(bus: ServoBus, clock: ManualClock, pose: Sequence[float], trigger: bool = True
                    ) -> GelloCalibration:
    """Run :class:`GelloCalibrator` with the timing of :func:`gello_calibration_scripts`."""
    c = GelloCalibrator(bus, pose, has_gripper=trigger)
    clock.t = 0.5
    c.capture_pose(bus.read_positions())
    for k in range(7):
        watch = c.watch(bus.read_positions())
        for t in np.linspace(1 + k, 2 + k, 25):
            clock.t = float(t)
            watch.update(bus.read_positions()[:7])
        c.finish_joint(k, watch)
    clock.t = 10.2
    c.capture_gripper_closed(bus.read_positions())
    return c.result()


def so101_calibration_scripts(middle: Sequence[float], lower: Sequence[float], upper: Sequence[float]
                              ) -> list[JointScript]:
    """Joint scripts for an SO-101 calibration: hold ``middle`` until t = 1 s, then sweep joint k during
    [1 + 3k, 4 + 3k] s: to its upper end (positive direction first), to its lower end (resting 0.3 s at
    each), back to the middle."""
    scripts = []
    for k in range(6):
        t0 = 1 + 3 * k
        scripts.append(JointScript([0, t0, t0 + 0.8, t0 + 1.1, t0 + 1.9, t0 + 2.2, t0 + 3],
                                   [middle[k], middle[k], upper[k], upper[k], lower[k], lower[k], middle[k]]))
    return scripts


def calibrate_so101(bus: ServoBus, clock: ManualClock, scale: float = 1.5) -> SO101Calibration:
    """Run :class:`SO101Calibrator` with the timing of :func:`so101_calibration_scripts`."""
    c = SO101Calibrator(bus)
    clock.t = 0.5
    c.capture_middle()
    for k in range(6):
        watch = c.watch(bus.read_positions())
        for t in np.linspace(1 + 3 * k, 4 + 3 * k, 90):
            clock.t = float(t)
            watch.update(bus.read_positions())
        c.finish_joint(k, watch)
    return c.result(scale=scale)
