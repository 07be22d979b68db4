"""GELLO driver against the emulated Dynamixel bus, through the real dynamixel-sdk."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.errors import DeviceError, RecipeError
from mgdata.motion.ik import kinematic_arm_model
from mgdata.sim.robot import HOME_Q
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.emulator.arms import ArmBuild, ManualClock
from mgdata.teleop.emulator.bus import Corruption
from mgdata.teleop.emulator.operator import calibrate_gello, gello_calibration_scripts
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.gello import GelloCalibration, gello_motors
from tests.helpers.teleop import GELLO_BUILD

TICK = 2 * np.pi / 4096
LIMITS = kinematic_arm_model().jnt_range


def _read_q(cal: GelloCalibration, build: ArmBuild, angles: np.ndarray, power_on: np.ndarray) -> np.ndarray:
    """Power the arm on at ``power_on``, move it to ``angles`` and read it through the calibration."""
    clock = ManualClock()
    scripts = [JointScript([0, 1], [power_on[k], angles[k]]) for k in range(7)] + [JointScript.constant(0.0)]
    with build.bus(scripts, clock) as emu:
        bus = ServoBus("dynamixel", emu.port, cal.motors)
        try:
            clock.t = 2.0
            return cal.joints_q(bus.read_positions())
        finally:
            bus.close()


def test_calibration_measures_signs_and_reads_true_angles(gello_cal: GelloCalibration) -> None:
    assert [j.sign for j in gello_cal.joints] == list(GELLO_BUILD.direction[:7])
    assert [j.id for j in gello_cal.joints] == list(range(1, 8)) and gello_cal.gripper_id == 8
    angles = HOME_Q + np.array([0.4, -0.3, 0.5, 0.6, -1.0, 0.9, -1.2])
    q = _read_q(gello_cal, GELLO_BUILD, angles, HOME_Q)
    assert np.max(np.abs(q - angles)) <= TICK + 1e-9


@settings(max_examples=12, deadline=None)
@given(st.lists(st.floats(0.02, 0.98), min_size=14, max_size=14))
def test_any_power_on_position_gives_the_same_reading(gello_cal: GelloCalibration,
                                                       fracs: list[float]) -> None:
    """The multi-turn counter starts in whichever turn the power-on position is in; the reading must not
    care."""
    lo, hi = LIMITS[:, 0], LIMITS[:, 1]
    power_on = lo + np.array(fracs[:7]) * (hi - lo)
    angles = lo + np.array(fracs[7:]) * (hi - lo)
    q = _read_q(gello_cal, GELLO_BUILD, angles, power_on)
    assert np.max(np.abs(q - angles)) <= TICK + 1e-9


def test_power_on_on_either_side_of_the_wrap(gello_cal: GelloCalibration) -> None:
    """Joint 4 reads 4094 at the calibration pose; powering on 3 ticks further puts the counter at 1."""
    d = GELLO_BUILD.direction[3]
    for delta_ticks in (-3, 0, 3, 5):
        power_on = HOME_Q.copy()
        power_on[3] += d * delta_ticks * TICK
        q = _read_q(gello_cal, GELLO_BUILD, HOME_Q, power_on)
        assert np.max(np.abs(q - HOME_Q)) <= TICK + 1e-9


def test_trigger_maps_to_travel(gello_cal: GelloCalibration) -> None:
    clock = ManualClock()
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript([0, 1], [0.0, 0.6])]
    with GELLO_BUILD.bus(scripts, clock) as emu:
        bus = ServoBus("dynamixel", emu.port, gello_cal.motors)
        travel = []
        for t in (0.0, 0.5, 1.0):
            clock.t = t
            travel.append(gello_cal.gripper(bus.read_positions()))
        bus.close()
    assert travel[0] == pytest.approx(0.0, abs=0.01)
    assert travel[1] == pytest.approx(0.5, abs=0.01)
    assert travel[2] == pytest.approx(1.0, abs=0.01)


def test_leader_torque_is_turned_off() -> None:
    """A servo left with torque on holds its shaft (the hand cannot move it); the driver must release it."""
    clock = ManualClock()
    scripts = [JointScript([0, 1], [a, a + 0.5]) for a in HOME_Q] + [JointScript.constant(0.0)]
    with GELLO_BUILD.bus(scripts, clock, process=False) as emu:
        for servo in emu.servos.values():
            servo.write(64, b"\x01")  # torque on, as a previous program may have left it
        bus = ServoBus("dynamixel", emu.port, gello_motors(True))
        assert not any(s.torque for s in emu.servos.values())
        first = bus.read_positions()
        clock.t = 1.0
        moved = bus.read_positions() - first
        bus.close()
    assert np.all(np.abs(moved[:7]) >= 0.5 / TICK - 2)


def test_swapped_ids_are_one_error_naming_both() -> None:
    build = dataclasses.replace(ArmBuild.gello(seed=4), swapped=(1, 2))
    clock = ManualClock()
    with build.bus(gello_calibration_scripts(HOME_Q), clock) as emu:
        bus = ServoBus("dynamixel", emu.port, gello_motors(True))
        with pytest.raises(DeviceError, match=r"joint2 \(id 2\).*joint3 \(id 3\).*swapped"):
            calibrate_gello(bus, clock, HOME_Q)
        bus.close()


def test_missing_servo_is_named_with_the_port() -> None:
    build = dataclasses.replace(ArmBuild.gello(seed=4), missing=(4,))
    with build.bus(gello_calibration_scripts(HOME_Q), ManualClock()) as emu, \
            pytest.raises(DeviceError, match=rf"joint5 \(id 5\) on {emu.port}"):
        ServoBus("dynamixel", emu.port, gello_motors(True))


def test_corrupted_replies_are_retried(gello_cal: GelloCalibration) -> None:
    build = dataclasses.replace(GELLO_BUILD, corruption=Corruption(rate=0.01, seed=1))
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript.constant(0.0)]
    with build.bus(scripts, ManualClock()) as emu:
        bus = ServoBus("dynamixel", emu.port, gello_cal.motors)
        for _ in range(400):
            q = gello_cal.joints_q(bus.read_positions())
            assert np.max(np.abs(q - HOME_Q)) <= TICK + 1e-9
        assert emu.corrupted > 0 and bus.read_errors > 0
        bus.close()


def test_a_servo_that_only_sends_garbage_is_named(gello_cal: GelloCalibration) -> None:
    build = dataclasses.replace(GELLO_BUILD, corruption=Corruption(rate=1.0, ids=(6,)))
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript.constant(0.0)]
    with build.bus(scripts, ManualClock()) as emu, pytest.raises(DeviceError, match=r"joint6 \(id 6\)"):
        ServoBus("dynamixel", emu.port, gello_cal.motors)


def test_missing_port_is_a_device_error(tmp_path: Path) -> None:
    port = str(tmp_path / "ttyUSB9")
    with pytest.raises(DeviceError, match=f"cannot open serial port {port}"):
        ServoBus("dynamixel", port, gello_motors(True))


def test_calibration_file_round_trip_and_bad_file(gello_cal: GelloCalibration, tmp_path: Path) -> None:
    path = tmp_path / "gello.json"
    gello_cal.save(path)
    assert GelloCalibration.load(path) == gello_cal
    path.write_text('{"arm": "gello", "joints": []}')
    with pytest.raises(RecipeError, match="not a valid GELLO calibration file"):
        GelloCalibration.load(path)


LEGACY = Path(__file__).parents[2] / ".venv" / "extras" / "dynamixel38"


@pytest.mark.skipif(not (LEGACY / "dynamixel_sdk").is_dir(),
                    reason="dynamixel-sdk 3.8 (LeRobot's pin) not in .venv/extras (scripts/setup.sh --dev)")
def test_lerobot_pinned_dynamixel_sdk_38(tmp_path: Path) -> None:
    """The same calibration and reading with the 3.8 line of dynamixel-sdk that LeRobot pins."""
    code = (
        "import dynamixel_sdk, numpy as np\n"
        f"assert dynamixel_sdk.__file__.startswith({str(LEGACY)!r}), dynamixel_sdk.__file__\n"
        "from tests.teleop.test_gello import _read_q\n"
        "from tests.helpers.teleop import GELLO_BUILD\n"
        "import teleop.bus; teleop.bus.DEFAULT_LATENCY_MS = 250.0\n"
        "from teleop.bus import ServoBus\n"
        "from teleop.emulator.arms import ManualClock\n"
        "from teleop.emulator.operator import calibrate_gello, gello_calibration_scripts\n"
        "from teleop.gello import gello_motors\n"
        "from mgdata.sim.robot import HOME_Q\n"
        "clock = ManualClock()\n"
        "with GELLO_BUILD.bus(gello_calibration_scripts(HOME_Q), clock) as emu:\n"
        "    bus = ServoBus('dynamixel', emu.port, gello_motors(True))\n"
        "    cal = calibrate_gello(bus, clock, HOME_Q)\n"
        "    bus.close()\n"
        "angles = HOME_Q + 0.3\n"
        "q = _read_q(cal, GELLO_BUILD, angles, HOME_Q - 0.2)\n"
        "print(float(np.max(np.abs(q - angles))))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(LEGACY), str(Path(__file__).parents[2])])}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout.strip()) <= TICK + 1e-9
