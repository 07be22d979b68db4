"""An emulated servo bus on a pseudo-terminal, spoken to by the real vendor SDKs.

The bus owns the device end of an ``os.openpty()`` pair and answers instruction packets from a thread, as the
servos on a half-duplex bus would; the SDK opens :attr:`EmulatedBus.port` like a USB serial adapter. Planted
faults are the servos the bus is built with (a missing id, two swapped ids, a shaft powered on near the
encoder wrap, see :mod:`teleop.emulator.arms`) plus reply corruption here.

Example::

    with EmulatedBus("dynamixel", servos) as bus:
        port = dynamixel_sdk.PortHandler(bus.port)
        ...
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import select
import threading
import tty
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mgdata.teleop.emulator import dynamixel, feetech
from mgdata.teleop.emulator.packet import Instruction
from mgdata.teleop.emulator.servo import EmulatedServo


@dataclass(frozen=True)
class Corruption:
    """Flip one payload or checksum byte in a fraction ``rate`` of the status packets of servos ``ids`` (all
    if empty): line noise that the checksum catches."""

    rate: float
    ids: tuple[int, ...] = ()
    seed: int = 0


class EmulatedBus:
    """Servos of one protocol family (``"dynamixel"`` Protocol 2.0 or ``"feetech"`` SCS/STS) on a pty.

    With ``process`` (the default) the servos answer from a forked process, as a real bus answers
    independently of the host; otherwise from a thread (then a test can inspect :attr:`servos` live).

    Attributes:
        port: the host-side device path to open with the SDK.
        servos: id -> servo, as found on the bus (the parent's copies when ``process``).
    """

    def __init__(self, family: str, servos: Sequence[EmulatedServo], corruption: Corruption | None = None,
                 *, process: bool = True) -> None:
        if family not in ("dynamixel", "feetech"):
            raise ValueError(f"unknown servo family {family!r}")
        self.family = family
        self.proto = dynamixel if family == "dynamixel" else feetech
        self.servos = {s.id: s for s in servos}
        self.corruption = corruption
        self._rng = np.random.default_rng(corruption.seed if corruption else 0)
        self._replies = multiprocessing.Value("l", 0, lock=False)
        self._corrupted = multiprocessing.Value("l", 0, lock=False)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        tty.setraw(self._master)
        self.port = os.ttyname(self._slave)
        self.process = process
        if process:  # a device of its own: answers on time however busy the host's interpreter is
            ctx = multiprocessing.get_context("fork")
            self._stop: Any = ctx.Event()
            self._worker: Any = ctx.Process(target=self._serve, name=f"emulated-{family}-bus", daemon=True)
        else:
            self._stop = threading.Event()
            self._worker = threading.Thread(target=self._serve, name=f"emulated-{family}-bus", daemon=True)

    @property
    def replies(self) -> int:
        """Status packets sent so far."""
        return int(self._replies.value)

    @property
    def corrupted(self) -> int:
        """Status packets corrupted so far."""
        return int(self._corrupted.value)

    @property
    def pid(self) -> int | None:
        """The answering process's id (``None`` for a thread or before ``start()``)."""
        return self._worker.pid if self.process else None

    def __enter__(self) -> EmulatedBus:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        self._worker.start()

    def close(self) -> None:
        """Stop answering and release the pty (idempotent)."""
        if getattr(self, "_closed", False):
            return
        self._closed = True
        self._stop.set()
        if self._worker.is_alive():
            self._worker.join(timeout=2.0)
        if self.process and self._worker.is_alive():
            self._worker.terminate()
            self._worker.join(timeout=2.0)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    # -- serving -----------------------------------------------------------------------------------------
    def _serve(self) -> None:
        buf = bytearray()
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if not ready:
                continue
            try:
                chunk = os.read(self._master, 4096)
            except OSError:
                return
            buf += chunk
            while (packet := self.proto.parse(buf)) is not None:
                out = self._answer(packet)
                if out:
                    os.write(self._master, out)

    def _reply(self, servo: EmulatedServo, params: bytes = b"", error: int = 0) -> bytes:
        packet = bytearray(self.proto.status(servo.id, error, params))
        self._replies.value += 1
        c = self.corruption
        if c is not None and (not c.ids or servo.id in c.ids) and self._rng.random() < c.rate:
            first = 9 if self.family == "dynamixel" else 5  # payload after the header, id, length, error
            i = int(self._rng.integers(min(first, len(packet) - 1), len(packet)))  # a data or checksum byte
            packet[i] ^= 0x5A
            self._corrupted.value += 1
        return bytes(packet)

    def _answer(self, p: Instruction) -> bytes:
        if not p.crc_ok:
            return b""  # a servo ignores a packet it cannot trust; the host times out
        dxl = self.family == "dynamixel"
        wide = 2 if dxl else 1  # address/length field width
        servo = self.servos.get(p.id)
        if p.instruction == self.proto.PING:
            targets = list(self.servos.values()) if p.id == self.proto.BROADCAST else [servo] if servo else []
            extra = lambda s: s.table.model.to_bytes(2, "little") + b"\x2e" if dxl else b""  # noqa: E731
            return b"".join(self._reply(s, extra(s)) for s in targets)
        if p.instruction in (self.proto.SYNC_READ, self.proto.SYNC_WRITE):
            addr = int.from_bytes(p.params[:wide], "little")
            size = int.from_bytes(p.params[wide:2 * wide], "little")
            rest = p.params[2 * wide:]
            if p.instruction == self.proto.SYNC_WRITE:
                for k in range(0, len(rest), size + 1):
                    target = self.servos.get(rest[k])
                    if target is not None:
                        target.write(addr, rest[k + 1:k + 1 + size])
                return b""
            return b"".join(self._reply(self.servos[i], self.servos[i].read(addr, size))
                            for i in rest if i in self.servos)
        if servo is None:
            return b""  # nobody with that id on the bus
        if p.instruction == self.proto.READ:
            addr = int.from_bytes(p.params[:wide], "little")
            size = int.from_bytes(p.params[wide:2 * wide], "little")
            return self._reply(servo, servo.read(addr, size))
        if p.instruction == self.proto.WRITE:
            addr = int.from_bytes(p.params[:wide], "little")
            servo.write(addr, p.params[wide:])
            return self._reply(servo)
        return self._reply(servo, error=dynamixel.ERR_INSTRUCTION if dxl else 0x08)
