"""SO-101 leader driver against the emulated Feetech bus, through the real feetech-servo-sdk."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mgdata.errors import DeviceError, RecipeError
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.emulator.arms import ArmBuild, ManualClock
from mgdata.teleop.emulator.bus import Corruption
from mgdata.teleop.emulator.operator import calibrate_so101, so101_calibration_scripts
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.so101.calibration import SO101Calibration, so101_motors
from mgdata.teleop.so101.kinematics import SO101Kinematics

TICK = 2 * np.pi / 4096
FK = SO101Kinematics()
# physical ranges, symmetric about the joint's zero (the model's "middle of the range" convention)
HALF = [*np.minimum(-FK.lower, FK.upper).tolist(), 0.9]
LOWER = [-h + 0.02 for h in HALF]
UPPER = [h - 0.02 for h in HALF]
GRIPPER_ZERO = 0.8  # rad, the jaw joint's angle at the middle of its range


def _calibrate(build: ArmBuild, middle: list[float]) -> tuple[SO101Calibration, ManualClock]:
    clock = ManualClock()
    with build.bus(so101_calibration_scripts(middle, LOWER, UPPER), clock) as emu:
        bus = ServoBus("feetech", emu.port, so101_motors())
        try:
            return calibrate_so101(bus, clock), clock
        finally:
            bus.close()


def _read(build: ArmBuild, cal: SO101Calibration, angles: np.ndarray) -> tuple[np.ndarray, float]:
    with build.bus([JointScript.constant(a) for a in angles], ManualClock()) as emu:
        bus = ServoBus("feetech", emu.port, cal.bus_motors)
        try:
            cal.apply(bus)
            ticks = bus.read_positions()
            return cal.joints_q(ticks), cal.gripper_open(ticks)
        finally:
            bus.close()


@pytest.mark.parametrize("wrist_roll_at_middle", [0.0, 2.5, -2.6])
def test_reads_true_angles_even_with_wrist_roll_far_from_centre(wrist_roll_at_middle: float) -> None:
    """LeRobot centres each joint where the operator held it; a wrist_roll held 2.5 rad off centre then has a
    range that crosses the encoder wrap. Ours follows the sweep across the wrap and re-centres."""
    build = ArmBuild.so101(seed=5)
    cal, _ = _calibrate(build, [0.0, 0.0, 0.0, 0.0, wrist_roll_at_middle, 0.0])
    for m in cal.motors.values():
        assert 0 <= m.range_min < m.range_max <= 4095
        assert abs((m.range_min + m.range_max) / 2 - 2047) <= 1
        assert abs(m.homing_offset) <= 2047
    for angles in (np.array([0.3, -0.5, 0.8, -1.0, 2.6, 0.5]), np.array([-1.5, 1.2, -1.3, 1.2, -2.6, -0.6])):
        q, grip = _read(build, cal, angles)
        assert np.max(np.abs(q - angles[:5])) <= 2 * TICK
        assert grip == pytest.approx((angles[5] - LOWER[5]) / (UPPER[5] - LOWER[5]), abs=0.01)


def test_drive_mode_follows_the_mounting() -> None:
    build = dataclasses.replace(ArmBuild.so101(seed=5), direction=(1, -1, 1, -1, -1, 1))
    cal, _ = _calibrate(build, [0.0] * 6)
    assert [m.drive_mode for m in cal.motors.values()] == [0, 1, 0, 1, 1, 0]
    q, _ = _read(build, cal, np.array([0.4, 0.4, 0.4, 0.4, 0.4, 0.0]))
    assert np.max(np.abs(q - 0.4)) <= 2 * TICK


def test_swapped_ids_are_one_error_naming_both() -> None:
    build = dataclasses.replace(ArmBuild.so101(seed=5), swapped=(4, 5))
    with pytest.raises(DeviceError, match=r"wrist_roll \(id 5\).*gripper \(id 6\).*swapped"):
        _calibrate(build, [0.0] * 6)


def test_missing_servo_is_named() -> None:
    build = dataclasses.replace(ArmBuild.so101(seed=5), missing=(2,))
    with build.bus([JointScript.constant(0.0)] * 6, ManualClock()) as emu, \
            pytest.raises(DeviceError, match=rf"elbow_flex \(id 3\) on {emu.port}"):
        ServoBus("feetech", emu.port, so101_motors())


def test_corrupted_replies_are_retried() -> None:
    build = dataclasses.replace(ArmBuild.so101(seed=5), corruption=Corruption(rate=0.01, seed=2))
    cal, _ = _calibrate(build, [0.0] * 6)
    with build.bus([JointScript.constant(0.2)] * 6, ManualClock()) as emu:
        bus = ServoBus("feetech", emu.port, cal.bus_motors)
        cal.apply(bus)  # fresh emulated servos: the homing offsets go back into their EEPROM
        for _ in range(300):
            assert np.max(np.abs(cal.joints_q(bus.read_positions()) - 0.2)) <= 2 * TICK
        assert emu.corrupted > 0 and bus.read_errors > 0
        bus.close()


def test_calibration_file_is_lerobot_format(tmp_path: Path) -> None:
    cal, _ = _calibrate(ArmBuild.so101(seed=5), [0.0] * 6)
    path = tmp_path / "so101.json"
    cal.save(path)
    assert SO101Calibration.load(path) == cal
    import json

    motors = json.loads(path.read_text())["motors"]
    assert set(motors["wrist_roll"]) == {"id", "drive_mode", "homing_offset", "range_min", "range_max"}
    path.write_text('{"arm": "so101", "motors": {}}')
    with pytest.raises(RecipeError, match="not a valid SO-101 calibration file"):
        SO101Calibration.load(path)


def test_forward_kinematics_matches_the_chain() -> None:
    """The gripper frame moves on a circle about the shoulder_pan axis (vertical, through the pan joint)."""
    p0, _ = FK.ee(np.zeros(5))
    p1, _ = FK.ee(np.array([0.7, 0, 0, 0, 0]))
    axis = FK.data.xpos[FK.model.body("shoulder").id]
    r0, r1 = np.linalg.norm((p0 - axis)[:2]), np.linalg.norm((p1 - axis)[:2])
    assert r0 == pytest.approx(r1, abs=1e-9) and p0[2] == pytest.approx(p1[2], abs=1e-9)
    assert 0.3 < p0[0] < 0.45  # the arm reaches forward along +x at its middle pose
