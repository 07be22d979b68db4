"""A single background thread that always works on the newest request: checks never queue up.

``submit`` replaces whatever is pending; the job in progress is told (through its ``stale`` callback) that a
newer request is waiting, so it can give up early. Each finished result goes to ``on_result`` with the
request's sequence number and the server-side times it was submitted and finished (``time.monotonic``).

Example::

    worker = LatestWorker(lambda pose, stale: checker.check(pose, stale), on_result=show)
    worker.submit(pose)       # called on every gizmo update; only the latest pose is ever finished
    worker.close()
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class Done(Generic[T]):
    """A finished request: its number, input, result, server-side times (s, ``time.monotonic``) and the
    job's own wall and CPU seconds (their difference is time the OS did not run the thread)."""

    seq: int
    request: Any
    result: T
    submitted: float
    finished: float
    wall: float = 0.0
    cpu: float = 0.0


class LatestWorker(Generic[T]):
    """Run ``job(request, stale)`` on the newest submitted request in one daemon thread."""

    def __init__(self, job: Callable[[Any, Callable[[], bool]], T | None],
                 on_result: Callable[[Done[T]], None]) -> None:
        self._job, self._on_result = job, on_result
        self._cond = threading.Condition()
        self._pending: tuple[int, Any, float] | None = None
        self._seq = 0
        self._closed = False
        self.skipped = 0  # requests replaced or abandoned before they finished
        self._thread = threading.Thread(target=self._loop, name="annotate-checks", daemon=True)
        self._thread.start()

    def submit(self, request: Any) -> int:
        """Queue ``request`` in place of any pending one; returns its sequence number."""
        with self._cond:
            self._seq += 1
            if self._pending is not None:
                self.skipped += 1
            self._pending = (self._seq, request, time.monotonic())
            self._cond.notify()
            return self._seq

    def _stale(self) -> bool:
        return self._pending is not None or self._closed

    def _loop(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                seq, request, submitted = self._pending  # type: ignore[misc]
                self._pending = None
            w0, c0 = time.monotonic(), time.thread_time()
            result = self._job(request, self._stale)
            if result is None:  # gave up: a newer request is waiting
                self.skipped += 1
                continue
            now = time.monotonic()
            self._on_result(Done(seq, request, result, submitted, now, now - w0, time.thread_time() - c0))

    def close(self) -> None:
        """Stop the thread (a job in progress is told to give up)."""
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout=5.0)
