"""Shared fixtures: emulated leaders calibrated through the real procedures, with the real SDKs."""

from __future__ import annotations

import pytest

from mgdata.sim.robot import HOME_Q
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.emulator.arms import ManualClock
from mgdata.teleop.emulator.operator import calibrate_gello, gello_calibration_scripts
from mgdata.teleop.gello import GelloCalibration, gello_motors
from tests.helpers.teleop import GELLO_BUILD

pytest.importorskip("dynamixel_sdk", reason="the teleop extra (dynamixel-sdk) is not installed")
pytest.importorskip("scservo_sdk", reason="the teleop extra (feetech-servo-sdk) is not installed")

@pytest.fixture(autouse=True)
def _patient_replies(monkeypatch: pytest.MonkeyPatch) -> None:
    """The emulated servos answer from a thread of this (often heavily loaded) host, not in microseconds as
    real ones do; a longer reply timeout keeps scheduling delays from looking like lost packets."""
    monkeypatch.setattr("mgdata.teleop.bus.DEFAULT_LATENCY_MS", 250.0)


@pytest.fixture(scope="session")
def gello_cal() -> GelloCalibration:
    clock = ManualClock()
    with GELLO_BUILD.bus(gello_calibration_scripts(HOME_Q), clock) as emu:
        bus = ServoBus("dynamixel", emu.port, gello_motors(True))
        try:
            return calibrate_gello(bus, clock, HOME_Q)
        finally:
            bus.close()
