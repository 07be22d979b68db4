"""The interactive calibration procedures behind ``mgdata teleop calibrate``: prompts between the steps of
:class:`~teleop.gello.GelloCalibrator` / :class:`~teleop.so101.calibration.SO101Calibrator`, with the bus
sampled continuously while the operator moves a joint."""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

from mgdata.teleop.bus import ServoBus
from mgdata.teleop.gello import GelloCalibration, GelloCalibrator, gello_motors
from mgdata.teleop.motion_check import MotionWatch
from mgdata.teleop.so101.calibration import MOTOR_NAMES, SO101Calibration, SO101Calibrator, so101_motors

Prompt = Callable[..., None]
Say = Callable[[str], None]


def _watch_until_enter(bus: ServoBus, watch: MotionWatch, prompt: Prompt, text: str, n: int | None = None
                       ) -> None:
    """Feed ``watch`` with readings until the operator presses Enter."""
    done = threading.Event()
    errors: list[BaseException] = []

    def sample() -> None:
        try:
            while not done.is_set():
                ticks = bus.read_positions()
                watch.update(ticks[:n] if n is not None else ticks)
        except BaseException as err:  # re-raised below, in the main thread
            errors.append(err)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    prompt(text, done)
    done.set()
    thread.join()
    if errors:
        raise errors[0]


def calibrate_gello_interactive(port: str, baudrate: int, pose: Sequence[float], trigger: bool,
                                prompt: Prompt, say: Say) -> GelloCalibration:
    bus = ServoBus("dynamixel", port, gello_motors(trigger), baudrate=baudrate)
    try:
        c = GelloCalibrator(bus, pose, has_gripper=trigger)
        prompt(f"Hold the GELLO in the known pose {[round(v, 3) for v in pose]} (rad), trigger released")
        c.capture_pose(bus.read_positions())
        for k in range(7):
            watch = c.watch(bus.read_positions())
            _watch_until_enter(bus, watch, prompt, f"Move joint{k + 1} about 30 degrees in the Panda's "
                               "positive direction, then back to the pose", n=7)
            sign = c.finish_joint(k, watch)
            say(f"  joint{k + 1}: servo id {bus.motors[k].id}, sign {sign:+d}")
        if trigger:
            prompt("Squeeze the trigger fully and hold it")
            c.capture_gripper_closed(bus.read_positions())
        return c.result()
    finally:
        bus.close()


def calibrate_so101_interactive(port: str, baudrate: int, scale: float, prompt: Prompt, say: Say
                                ) -> SO101Calibration:
    bus = ServoBus("feetech", port, so101_motors(), baudrate=baudrate)
    try:
        c = SO101Calibrator(bus)
        prompt("Hold the SO-101 leader with every joint in the middle of its range")
        c.capture_middle()
        for k, name in enumerate(MOTOR_NAMES):
            watch = c.watch(bus.read_positions())
            _watch_until_enter(bus, watch, prompt, f"Move {name} first towards its positive end, then "
                               "through its whole range between the stops, then back to the middle")
            rec = c.finish_joint(k, watch)
            say(f"  {name}: range {rec.range_min}..{rec.range_max} ticks, homing offset {rec.homing_offset}, "
                f"drive mode {rec.drive_mode}")
        return c.result(scale=scale)
    finally:
        bus.close()
