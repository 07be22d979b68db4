"""The leader reader: a child process that sync-reads the leader's servos at ``reader_hz`` (≥ 100 Hz) and
sends every reading (monotonic time, ticks) through a pipe; the 20 Hz control loop drains the pipe, takes the
newest reading and logs every reading of the episode in progress (the raw leader stream, from which the
episode can be re-simulated).

Why a process: the control thread renders cameras in MuJoCo, which holds the GIL for up to ~50 ms; a reader
thread needs the GIL after every serial read, so its readings were late and the leader was read at only
41–69 Hz during the loop. The child has its own interpreter: its rate does not depend on the loop's.

The child opens its own :class:`~teleop.bus.ServoBus` on the same port, from the parent bus's parameters
(``multiprocessing``'s spawn context: no fork of a threaded process). A failed read in the child (after the
bus's own retries) is retried; when no reading has succeeded for ``stale_s``, :meth:`LeaderReader.latest`
raises in the control loop with the last error (naming the port and the motor). The loop never runs on an
old pose. A bug in the child, or the child's death, is one :class:`DeviceError` in the loop. The child
ignores Ctrl-C (the parent decides when to stop) and ends by itself when the parent is gone (its next send
fails).

Example::

    reader = LeaderReader(bus, reader_hz=120.0, stale_s=0.25)
    reader.start_log()
    index, ticks = reader.latest()        # index of the newest reading in the episode's log
    times, log = reader.take_log()        # (N,) s, (N, n_motors) ticks
    reader.close()
"""

from __future__ import annotations

import contextlib
import multiprocessing
import select
import signal
import struct
import time
import traceback
from collections import deque
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from mgdata.errors import DeviceError
from mgdata.teleop.bus import Motor, ServoBus

START_TIMEOUT_S = 60.0
"""Longest wait (s) for the child to start and open the bus (a fresh interpreter on a loaded host)."""

_HEAD = struct.Struct("<cdd")  # tag, time s, read wall time s; a reading's int64 ticks follow
_READING, _ERROR, _FATAL, _OPEN = b"R", b"E", b"F", b"O"


class LeaderReader:
    """Reads ``bus``'s port at ``reader_hz`` in a child process (see the module docstring). ``bus`` stays
    open and idle in this process.

    Attributes:
        port, motors: the bus's; pid: the child's process id; recent_reads: (time s, read wall time s) of
        the latest readings drained (for benchmarks).
    """

    def __init__(self, bus: ServoBus, reader_hz: float, stale_s: float) -> None:
        self.port, self.motors = bus.port, bus.motors
        self.stale_s = stale_s
        self.recent_reads: deque[tuple[float, float]] = deque(maxlen=100_000)
        self._latest: tuple[float, np.ndarray] | None = None
        self._log: list[tuple[float, np.ndarray]] | None = None
        self._error: str | None = None  # the latest read error
        self._fatal: str | None = None
        ctx = multiprocessing.get_context("spawn")
        self._counts: Any = ctx.RawArray("q", 3)  # successful reads, failed reads, sync reads retried
        self._stop: Any = ctx.RawValue("b", 0)
        self._t0 = time.monotonic()
        self._conn, child_conn = ctx.Pipe(duplex=False)
        params = (bus.family, bus.port, bus.motors, bus.baudrate, bus.retries, bus.latency_ms)
        self._proc = ctx.Process(target=_serve, args=(params, 1.0 / reader_hz, self._t0, child_conn,
                                                      self._counts, self._stop),
                                 name="leader-reader", daemon=True)
        self._proc.start()
        child_conn.close()  # the child holds the write end alone: its death is an EOF here
        self.pid = self._proc.pid
        self._opened = time.monotonic()
        try:
            self._await_open()
        except BaseException:
            self.close()
            raise

    def _await_open(self) -> None:
        deadline = time.monotonic() + START_TIMEOUT_S
        while self._conn.poll(max(0.0, deadline - time.monotonic())):
            msg = self._recv()
            if msg[:1] == _OPEN:
                self._opened = time.monotonic()
                return
            if msg[:1] == _FATAL:
                raise DeviceError(f"leader on {self.port}: {msg[1:].decode()}")
            self._take(msg)
        raise DeviceError(f"leader on {self.port}: the reader process did not start within "
                          f"{START_TIMEOUT_S:.0f} s")

    def _recv(self) -> bytes:
        try:
            return self._conn.recv_bytes()
        except (EOFError, OSError):
            self._proc.join(timeout=1.0)
            code = self._proc.exitcode
            how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
            self._fatal = self._fatal or f"the reader process ended unexpectedly ({how})"
            raise DeviceError(f"leader on {self.port}: {self._fatal}") from None

    def _take(self, msg: bytes) -> None:
        tag = msg[:1]
        if tag == _READING:
            _, t, read_s = _HEAD.unpack_from(msg)
            ticks = np.frombuffer(msg, dtype=np.int64, offset=_HEAD.size).copy()
            self._latest = (t, ticks)
            self.recent_reads.append((t, read_s))
            if self._log is not None:
                self._log.append((t, ticks))
        elif tag == _ERROR:
            self._error = msg[1:].decode()
        elif tag == _FATAL:
            self._fatal = msg[1:].decode()

    def _drain(self) -> None:
        """Take every message the child has sent; raise on a bug in the child or its death."""
        if self._fatal is not None:
            raise DeviceError(f"leader on {self.port}: {self._fatal}")
        while self._conn.poll():
            self._take(self._recv())
            if self._fatal is not None:
                raise DeviceError(f"leader on {self.port}: {self._fatal}")

    @property
    def reads(self) -> int:
        """Successful reads so far."""
        return int(self._counts[0])

    @property
    def failures(self) -> int:
        """Reads that failed after the bus's retries."""
        return int(self._counts[1])

    @property
    def retried(self) -> int:
        """Sync reads that failed and were retried by the bus."""
        return int(self._counts[2])

    def now(self) -> float:
        """The readings' clock (s): the time stamp a reading made now would carry."""
        return time.monotonic() - self._t0

    @property
    def rate_hz(self) -> float:
        """Successful reads per second since the bus was opened in the child."""
        return self.reads / max(1e-9, time.monotonic() - self._opened)

    def latest(self) -> tuple[int, np.ndarray]:
        """(index in the episode's log, or -1 when not logging; ticks) of the newest reading."""
        deadline = time.monotonic() + self.stale_s
        while True:
            self._drain()
            latest = self._latest
            if latest is not None and self.now() - latest[0] <= self.stale_s:
                return (len(self._log) - 1 if self._log is not None else -1), latest[1]
            left = deadline - time.monotonic()
            if left < 0:
                why = f": {self._error}" if self._error is not None else ""
                raise DeviceError(f"leader on {self.port}: no fresh reading for {self.stale_s} s{why}")
            self._conn.poll(min(left, 0.01))

    def start_log(self) -> None:
        """Start logging every reading (a new episode), from the newest one if it is fresh."""
        self._drain()
        fresh = self._latest is not None and self.now() - self._latest[0] <= self.stale_s
        self._log = [self._latest] if fresh and self._latest is not None else []

    def take_log(self) -> tuple[np.ndarray, np.ndarray]:
        """Stop logging; return (times s, (N, n_motors) ticks) of the episode's readings."""
        try:
            self._drain()
        finally:
            log, self._log = self._log or [], None
        if not log:
            return np.zeros(0), np.zeros((0, len(self.motors)), dtype=np.int64)
        return np.array([t for t, _ in log]), np.stack([v for _, v in log])

    def close(self) -> None:
        """Stop and join the child (idempotent)."""
        self._stop.value = 1
        self._conn.close()  # a child blocked in a send gets a broken pipe
        self._proc.join(timeout=2.0)
        if self._proc.is_alive():
            self._proc.kill()
            self._proc.join(timeout=2.0)


_Params = tuple[str, str, tuple[Motor, ...], int, int, float]
"""The bus's family, port, motors, baud rate, retries and latency allowance (ms)."""


def _serve(params: _Params, period: float, t0: float, conn: Connection, counts: Any, stop: Any) -> None:
    """The child: open the bus, then read it every ``period`` s until told to stop or the parent is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole process group: the parent decides
    try:
        family, port, motors, baudrate, retries, latency_ms = params
        try:
            bus = ServoBus(family, port, motors, baudrate=baudrate, retries=retries, latency_ms=latency_ms)
        except DeviceError as err:
            conn.send_bytes(_FATAL + str(err).encode())
            return
        try:
            conn.send_bytes(_OPEN)
            _read_loop(bus, period, t0, conn, counts, stop)
        finally:
            bus.close()
    except BrokenPipeError:  # the parent closed its end or is gone
        return
    except BaseException as err:  # a bug: one line for the loop, with where it happened
        where = traceback.extract_tb(err.__traceback__)[-1]
        text = f"reader process failed: {type(err).__name__}: {err} ({where.filename}:{where.lineno})"
        with contextlib.suppress(OSError):
            conn.send_bytes(_FATAL + text.encode())


def _read_loop(bus: ServoBus, period: float, t0: float, conn: Connection, counts: Any, stop: Any) -> None:
    fd = conn.fileno()
    next_t = time.monotonic()
    while not stop.value:
        start = time.monotonic()
        try:
            ticks = bus.read_positions()
        except DeviceError as err:  # transient (a stalled host) or lasting: the parent's staleness check
            counts[1] += 1
            counts[2] = bus.read_errors
            _send(conn, fd, _ERROR + str(err).encode())
            time.sleep(period)  # a lasting fault (an unplugged adapter) fails at once: no busy loop
            next_t = time.monotonic()
            continue
        now = time.monotonic()
        counts[0] += 1
        counts[2] = bus.read_errors
        _send(conn, fd, _HEAD.pack(_READING, now - t0, now - start) + ticks.astype(np.int64).tobytes())
        next_t += period
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            next_t = time.monotonic()


def _send(conn: Connection, fd: int, msg: bytes) -> None:
    """Send ``msg`` unless the pipe is full (the parent is not draining: it is not recording). A message is
    far below ``PIPE_BUF``, so a write into a writable pipe is whole and does not block; a closed pipe is
    writable and raises :class:`BrokenPipeError`."""
    if select.select([], [fd], [], 0)[1]:
        conn.send_bytes(msg)
