"""The leader reader process and the missing-extra error."""

from __future__ import annotations

import importlib
import multiprocessing
import os
import random
import signal
import threading
import time

import numpy as np
import pytest

from mgdata.errors import DeviceError, MgdataError
from mgdata.sim.robot import HOME_Q
from mgdata.teleop import sdk
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.emulator.arms import ManualClock
from mgdata.teleop.emulator.bus import EmulatedBus
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.gello import GelloCalibration
from mgdata.teleop.reader import LeaderReader
from tests.helpers.teleop import GELLO_BUILD


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


def _leader(gello_cal: GelloCalibration) -> tuple[EmulatedBus, ServoBus]:
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript.constant(0.0)]
    emu = GELLO_BUILD.bus(scripts, ManualClock())
    emu.start()
    return emu, ServoBus("dynamixel", emu.port, gello_cal.motors)


def test_the_reader_keeps_its_rate_while_the_loop_holds_the_gil(gello_cal: GelloCalibration) -> None:
    emu, bus = _leader(gello_cal)
    reader = LeaderReader(bus, reader_hz=200.0, stale_s=1.0)
    values = [random.random() for _ in range(1_500_000)]
    beats: list[float] = []  # a thread of this process that runs whenever it can get the GIL
    done = threading.Event()

    def beat() -> None:
        while not done.is_set():
            beats.append(reader.now())
            time.sleep(0.0005)

    heart = threading.Thread(target=beat)
    try:
        reader.start_log()
        heart.start()
        time.sleep(0.3)
        start = reader.now()
        values.sort()  # one C call that holds the GIL throughout (float compares never enter the eval loop)
        end = reader.now()
        time.sleep(0.3)
        times, _ = reader.take_log()
    finally:
        done.set()
        heart.join()
        reader.close()
        bus.close()
        emu.close()
    held = end - start
    assert held >= 0.1, f"the sort took only {held * 1000:.0f} ms"
    # checked from outside: no other thread of this process ran during the sort, so it did hold the GIL
    assert not [t for t in beats if start + 0.01 < t < end - 0.01]
    inside = times[(times > start) & (times < end)]
    # a reader thread makes none (its time stamp needs the GIL); the process keeps reading, though on this
    # loaded 2-core host it shares the cores with the sort and the emulated device, so not at the full rate
    gaps = np.diff(np.concatenate([[start], inside, [end]]))
    why = f"{len(inside)} readings in {held * 1000:.0f} ms, largest gap {gaps.max() * 1000:.0f} ms"
    assert len(inside) >= 5 and gaps.max() < held / 2, why


def _reader_children() -> list[multiprocessing.process.BaseProcess]:
    return [p for p in multiprocessing.active_children() if p.name == "leader-reader"]


def test_a_leader_gone_before_the_reader_starts_is_one_clear_error(gello_cal: GelloCalibration) -> None:
    emu, bus = _leader(gello_cal)
    emu.close()  # unplugged between opening the bus and starting the reader
    try:
        with pytest.raises(DeviceError, match=rf"^leader on {emu.port}: .*{emu.port}"):
            LeaderReader(bus, reader_hz=200.0, stale_s=1.0)
    finally:
        bus.close()
    assert not _reader_children()


def test_a_killed_reader_process_is_one_clear_error(gello_cal: GelloCalibration) -> None:
    emu, bus = _leader(gello_cal)
    reader = LeaderReader(bus, reader_hz=200.0, stale_s=1.0)
    try:
        reader.latest()
        os.kill(reader.pid, signal.SIGKILL)
        time.sleep(0.5)
        for _ in range(2):  # and again on the next step
            with pytest.raises(DeviceError, match=rf"^leader on {emu.port}: the reader process ended "
                               r"unexpectedly \(killed by signal 9\)$"):
                reader.latest()
    finally:
        reader.close()
        bus.close()
        emu.close()
    assert not _reader_children()


def test_a_bug_in_the_reader_process_is_one_clear_error(gello_cal: GelloCalibration) -> None:
    emu, bus = _leader(gello_cal)
    bus.family = "no-such-family"  # the child's bus code fails on it (a KeyError, not a DeviceError)
    try:
        with pytest.raises(DeviceError, match=rf"^leader on {emu.port}: reader process failed: KeyError: "
                           r"'no-such-family' \(.*bus\.py:\d+\)$"):
            LeaderReader(bus, reader_hz=200.0, stale_s=1.0)
    finally:
        bus.close()
        emu.close()
    assert not _reader_children()


def test_missing_extra_names_it(monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.import_module

    def fake(name: str, *args: object) -> object:
        if name == "scservo_sdk":
            raise ImportError(name)
        return real(name, *args)

    monkeypatch.setattr(sdk.importlib, "import_module", fake)
    with pytest.raises(MgdataError, match=r"'feetech-servo-sdk'.*teleop extra"):
        sdk.require("feetech")
