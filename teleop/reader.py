"""The leader reader: a thread that sync-reads the leader's servos at ``reader_hz`` (≥ 100 Hz), keeps the
latest reading for the 20 Hz control loop and logs every reading of the episode in progress (the raw leader
stream, from which the episode can be re-simulated).

A failed read in the thread (after the bus's own retries) is retried; when no reading has succeeded for
``stale_s``, :meth:`LeaderReader.latest` raises in the control loop with the last error (naming the port and
the motor). The loop never runs on an old pose.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from mgdata.errors import DeviceError
from teleop.bus import ServoBus


class LeaderReader:
    """Reads ``bus`` in a daemon thread (see the module docstring).

    Attributes:
        rate_hz: the measured read rate over the thread's life; reads: successful reads so far.
    """

    def __init__(self, bus: ServoBus, reader_hz: float, stale_s: float) -> None:
        self.bus = bus
        self.period = 1.0 / reader_hz
        self.stale_s = stale_s
        self._lock = threading.Lock()
        self._latest: tuple[int, float, np.ndarray] | None = None
        self._log: list[tuple[float, np.ndarray]] | None = None
        self._log_base = 0
        self._error: BaseException | None = None  # the latest read error
        self._fatal = False
        self.failures = 0  # reads that failed after the bus's retries
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._reads = 0
        self._thread = threading.Thread(target=self._run, name="leader-reader", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        next_t = time.monotonic()
        seq = 0
        while not self._stop.is_set():
            try:
                ticks = self.bus.read_positions()
            except DeviceError as err:  # transient (a stalled host) or lasting: the staleness check decides
                self._error = err
                self.failures += 1
                continue
            except BaseException as err:  # a bug: re-raised in the control loop
                self._error = err
                self._fatal = True
                return
            now = time.monotonic() - self._t0
            with self._lock:
                self._latest = (seq, now, ticks)
                if self._log is not None:
                    self._log.append((now, ticks))
            seq += 1
            self._reads += 1
            next_t += self.period
            delay = next_t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                next_t = time.monotonic()

    @property
    def reads(self) -> int:
        return self._reads

    @property
    def rate_hz(self) -> float:
        return self._reads / max(1e-9, time.monotonic() - self._t0)

    def latest(self) -> tuple[int, np.ndarray]:
        """(index in the episode's log, or -1 when not logging; ticks) of the newest reading."""
        if self._fatal:
            raise DeviceError(f"leader on {self.bus.port}: {self._error}")
        deadline = time.monotonic() + self.stale_s
        while True:
            with self._lock:
                latest = self._latest
                log_len = len(self._log) if self._log is not None else 0
            if latest is not None and time.monotonic() - self._t0 - latest[1] <= self.stale_s:
                return (log_len - 1 if self._log is not None else -1), latest[2]
            if self._fatal:
                raise DeviceError(f"leader on {self.bus.port}: {self._error}")
            if time.monotonic() > deadline:
                why = f": {self._error}" if self._error is not None else ""
                raise DeviceError(f"leader on {self.bus.port}: no fresh reading for {self.stale_s} s{why}")
            time.sleep(0.001)

    def start_log(self) -> None:
        """Start logging every reading (a new episode)."""
        with self._lock:
            self._log = [] if self._latest is None else [(self._latest[1], self._latest[2])]

    def take_log(self) -> tuple[np.ndarray, np.ndarray]:
        """Stop logging; return (times s, (N, n_motors) ticks) of the episode's readings."""
        with self._lock:
            log, self._log = self._log or [], None
        if not log:
            return np.zeros(0), np.zeros((0, len(self.bus.motors)), dtype=np.int64)
        return np.array([t for t, _ in log]), np.stack([v for _, v in log])

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
