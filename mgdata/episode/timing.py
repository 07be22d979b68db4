"""Where an attempt's time goes: IK/planning, physics, rendering (+ labelling), encoding, writing, setup.

The time is the process's CPU time (``time.process_time``: user + system of this process), measured for the
summary and the benchmark only; it never influences what is generated. CPU time, not wall time, so that a
phase's share does not depend on what else the machine runs (2 workers on 2 cores, a test suite beside).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, fields

PHASES: tuple[str, ...] = ("planning", "physics", "rendering", "encoding", "writing", "setup")


@dataclass
class Timings:
    """Seconds spent per phase (``rendering`` includes labelling and monitoring, which cost ~0.1 ms/step;
    ``setup`` is building a task's scene, executor and cameras the first time a worker meets the task, the
    initial-state gate's IK being ``planning``)."""

    planning: float = 0.0
    physics: float = 0.0
    rendering: float = 0.0
    encoding: float = 0.0
    writing: float = 0.0
    setup: float = 0.0

    @contextmanager
    def measure(self, phase: str) -> Iterator[None]:
        """Add the CPU time of the ``with`` body to ``phase``."""
        start = time.process_time()
        try:
            yield
        finally:
            setattr(self, phase, getattr(self, phase) + time.process_time() - start)

    def add(self, other: Timings) -> None:
        for f in fields(self):
            setattr(self, f.name, getattr(self, f.name) + getattr(other, f.name))

    @property
    def total(self) -> float:
        return sum(getattr(self, f.name) for f in fields(self))

    def as_dict(self) -> dict[str, float]:
        return {f.name: getattr(self, f.name) for f in fields(self)}
