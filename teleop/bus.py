"""A leader arm's servo bus through the real vendor SDK: open, check every motor, read positions fast.

:class:`ServoBus` opens the serial port, pings each named motor and checks its model number, turns torque off
(a leader is moved by hand), and sync-reads present positions. A read that fails (a corrupted or missing
status packet) is retried ``retries`` times; a motor that stays silent is a :class:`DeviceError` naming the
port and the motor. Nothing here falls back to a fake device.

Example::

    bus = ServoBus("dynamixel", "/dev/ttyUSB0", [Motor("joint1", 1, 1200), ...], baudrate=1_000_000)
    ticks = bus.read_positions()      # int64 (n,), in motor order
    bus.close()
"""

from __future__ import annotations

import termios
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mgdata.errors import DeviceError
from mgdata.teleop.sdk import require

_PORT_ERRORS = (OSError, termios.error)
"""What pyserial raises when the adapter goes away (SerialException is an OSError; tcflush: termios')."""

DEFAULT_LATENCY_MS = 16.0
"""The SDKs' allowance (ms) for the USB-serial adapter's latency, part of every reply timeout (16: FTDI's
default). An emulated bus answering from a thread of a heavily loaded host needs more."""


READ_BLOCK_S = 0.002
"""Longest wait (s) of one serial read inside the SDKs' reply loops before they check their timeout."""


@dataclass(frozen=True)
class Motor:
    """One servo of a leader arm: its role (``joint3``, ``wrist_roll``), bus id and expected model number."""

    name: str
    id: int
    model: int


@dataclass(frozen=True)
class _Family:
    sdk: str
    protocol: float | int
    torque_enable: int
    present_position: int
    position_size: int
    homing_offset: int | None


_FAMILIES = {
    "dynamixel": _Family("dynamixel", 2.0, torque_enable=64, present_position=132, position_size=4,
                         homing_offset=None),
    "feetech": _Family("feetech", 0, torque_enable=40, present_position=56, position_size=2,
                       homing_offset=31),
}


class ServoBus:
    """The motors of one leader arm on one serial port (see the module docstring).

    Attributes:
        port: the device path; ``motors``: in reading order; ``read_errors``: failed sync reads so far
        (each retried); ``latency_ms``: the adapter latency allowed for in every reply timeout
        (:data:`DEFAULT_LATENCY_MS` unless given).
    """

    def __init__(self, family: str, port: str, motors: Sequence[Motor], *, baudrate: int = 1_000_000,
                 retries: int = 3, latency_ms: float | None = None) -> None:
        self.family = family
        self.port = port
        self.baudrate = baudrate
        self.motors = tuple(motors)
        self.retries = retries
        self.latency_ms = DEFAULT_LATENCY_MS if latency_ms is None else latency_ms
        self.drain_s = 0.05
        self.read_errors = 0
        self._f = _FAMILIES[family]
        self._sdk: Any = require(self._f.sdk)
        self._sdk.port_handler.LATENCY_TIMER = self.latency_ms  # read by every timeout computation
        self._port = self._sdk.PortHandler(port)
        try:
            opened = self._port.openPort()
        except Exception as err:  # pyserial raises SerialException for a missing or busy device
            raise DeviceError(f"cannot open serial port {port}: {err}") from None
        if not opened or not self._port.setBaudRate(baudrate):
            raise DeviceError(f"cannot open serial port {port} at {baudrate} baud")
        # The SDKs open the port non-blocking and poll it in a loop while a reply is due: a busy wait that
        # holds a core (and the GIL, between reads) for the whole round trip. A short blocking read waits in
        # the kernel instead and returns as soon as the bytes asked for are in; the SDKs' own packet
        # timeouts are unchanged.
        self._port.ser.timeout = READ_BLOCK_S
        self._ph = self._sdk.PacketHandler(self._f.protocol)
        try:
            self._check_motors()
            for m in self.motors:
                self.write1(m, self._f.torque_enable, 0)
        except DeviceError:
            self.close()
            raise
        self._group = self._sdk.GroupSyncRead(self._port, self._ph, self._f.present_position,
                                              self._f.position_size)
        for m in self.motors:
            self._group.addParam(m.id)

    def _drain(self) -> None:
        """After a failed transaction: wait out a late reply (a loaded host or a slow USB adapter can deliver
        it after the SDK's timeout), then drop it, so it cannot be taken for the answer to the retry."""
        time.sleep(self.drain_s)
        try:
            self._port.clearPort()
        except _PORT_ERRORS as err:
            raise DeviceError(f"serial port {self.port} failed: {err}") from None

    def _call(self, fn: Any, *args: Any) -> tuple:
        """An SDK transaction; an exception on a malformed reply (the SDKs index short packets) counts as a
        corrupt reply, like a checksum error."""
        try:
            return fn(self._port, *args)
        except (IndexError, ValueError, TypeError):
            return (None, self._sdk.COMM_RX_CORRUPT, 0)
        except _PORT_ERRORS as err:  # the adapter was unplugged
            raise DeviceError(f"serial port {self.port} failed: {err}") from None

    def _where(self, m: Motor) -> str:
        return f"motor {m.name} (id {m.id}) on {self.port}"

    def _check_motors(self) -> None:
        silent = []
        for m in self.motors:
            for _ in range(self.retries + 1):
                model, result, _err = self._call(self._ph.ping, m.id)
                if result == self._sdk.COMM_SUCCESS:
                    break
                self._drain()
            else:
                silent.append(m)
                continue
            if model != m.model:
                raise DeviceError(f"{self._where(m)} reports model number {model}, expected {m.model}; "
                                  "check the wiring and the motor ids")
        if silent:
            names = ", ".join(f"{m.name} (id {m.id})" for m in silent)
            raise DeviceError(f"no reply from motor(s) {names} on {self.port}: check power, cabling and ids")

    def write1(self, m: Motor, address: int, value: int) -> None:
        """Write one byte to a motor's control table (retried)."""
        for _ in range(self.retries + 1):
            result, err = self._call(self._ph.write1ByteTxRx, m.id, address, value)[-2:]
            if result == self._sdk.COMM_SUCCESS and err == 0:
                return
            self._drain()
        raise DeviceError(f"{self._where(m)} did not accept a write to address {address}")

    def read(self, m: Motor, address: int, size: int) -> int:
        """Read an unsigned 1/2/4-byte value from a motor's control table (retried)."""
        fn = {1: self._ph.read1ByteTxRx, 2: self._ph.read2ByteTxRx, 4: self._ph.read4ByteTxRx}[size]
        for _ in range(self.retries + 1):
            value, result, err = self._call(fn, m.id, address)
            if result == self._sdk.COMM_SUCCESS and err == 0:
                return int(value)
            self._drain()
        raise DeviceError(f"{self._where(m)} did not answer a read of address {address}")

    def write2(self, m: Motor, address: int, value: int) -> None:
        """Write a 2-byte value (retried)."""
        for _ in range(self.retries + 1):
            result, err = self._call(self._ph.write2ByteTxRx, m.id, address, value)[-2:]
            if result == self._sdk.COMM_SUCCESS and err == 0:
                return
            self._drain()
        raise DeviceError(f"{self._where(m)} did not accept a write to address {address}")

    def read_positions(self) -> np.ndarray:
        """Present positions (ticks, int64, motor order): Dynamixel's multi-turn count as a signed 32-bit
        value, Feetech's 12-bit position."""
        size = self._f.position_size
        for _ in range(self.retries + 1):
            try:
                result = self._group.txRxPacket()
            except (IndexError, ValueError, TypeError):
                result = self._sdk.COMM_RX_CORRUPT
            except _PORT_ERRORS as err:  # the adapter was unplugged
                raise DeviceError(f"serial port {self.port} failed: {err}") from None
            addr = self._f.present_position
            if result == self._sdk.COMM_SUCCESS and all(self._group.isAvailable(m.id, addr, size)
                                                        for m in self.motors):
                # (a short reply with a valid checksum, e.g. a late status of an earlier write, is not data)
                raw = [self._group.getData(m.id, addr, size) for m in self.motors]
                out = np.asarray(raw, dtype=np.int64)
                if size == 4:
                    out = np.where(out >= 1 << 31, out - (1 << 32), out)
                return out
            self.read_errors += 1
            self._drain()
        self._blame()
        raise AssertionError("unreachable")

    def _blame(self) -> None:
        """After a sync read failed every retry: find the motor(s) that do not answer and say so."""
        bad = []
        for m in self.motors:
            ok = False
            for _ in range(self.retries + 1):
                read = {2: self._ph.read2ByteTxRx, 4: self._ph.read4ByteTxRx}[self._f.position_size]
                _value, result, _err = self._call(read, m.id, self._f.present_position)
                if result == self._sdk.COMM_SUCCESS:
                    ok = True
                    break
                self._drain()
            if not ok:
                bad.append(f"{m.name} (id {m.id})")
        who = ", ".join(bad) if bad else "an unidentified motor (each answers alone)"
        raise DeviceError(f"reading positions on {self.port} failed {self.retries + 1} times in a row: "
                          f"no valid reply from {who}; check cabling and power")

    def close(self) -> None:
        """Close the port (idempotent)."""
        if self._port is not None:
            self._port.closePort()
            self._port = None
