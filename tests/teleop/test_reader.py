"""The leader reader thread and the missing-extra error."""

from __future__ import annotations

import importlib
import time

import numpy as np
import pytest

from mgdata.errors import DeviceError, MgdataError
from mgdata.sim.robot import HOME_Q
from teleop import sdk
from teleop.bus import ServoBus
from teleop.emulator.arms import ManualClock
from teleop.emulator.script import JointScript
from teleop.gello import GelloCalibration
from teleop.reader import LeaderReader
from tests.teleop.conftest import GELLO_BUILD


def test_reader_logs_readings_and_reports_an_unplugged_leader(gello_cal: GelloCalibration) -> None:
    clock = ManualClock()
    scripts = [JointScript([0, 1], [a, a + 0.2]) for a in HOME_Q] + [JointScript.constant(0.0)]
    emu = GELLO_BUILD.bus(scripts, clock)
    emu.start()
    bus = ServoBus("dynamixel", emu.port, gello_cal.motors)
    reader = LeaderReader(bus, reader_hz=200.0, stale_s=1.0)
    try:
        reader.start_log()
        time.sleep(0.3)
        clock.t = 1.0
        time.sleep(0.3)
        index, ticks = reader.latest()
        times, log = reader.take_log()
        assert index >= 0 and len(times) == len(log) >= 10 and np.all(np.diff(times) > 0)
        assert np.allclose(gello_cal.joints_q(ticks), HOME_Q + 0.2, atol=0.002)  # the newest reading
        emu.close()  # the leader is unplugged
        time.sleep(1.5)
        with pytest.raises(DeviceError, match=rf"leader on {emu.port}: no fresh reading for 1.0 s: serial "
                           rf"port {emu.port} failed"):
            reader.latest()
    finally:
        reader.close()
        bus.close()
        emu.close()


def test_missing_extra_names_it(monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.import_module

    def fake(name: str, *args: object) -> object:
        if name == "scservo_sdk":
            raise ImportError(name)
        return real(name, *args)

    monkeypatch.setattr(sdk.importlib, "import_module", fake)
    with pytest.raises(MgdataError, match=r"'feetech-servo-sdk'.*teleop extra"):
        sdk.require("feetech")
