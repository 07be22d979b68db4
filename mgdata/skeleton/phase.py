"""Phases: a demonstration as named steps, each done when a physical predicate holds.

A skeleton's segments fall into phases (the jar's: close the lid, then carry the jar), each with an
optional postcondition, ``done``: the name of a proposition of the family's recipe (its ``[success.*]``
goal propositions or its spec's propositions, e.g. ``jar_closed``). A demonstration from the task's
initial state runs every phase; one **restarted** from another state (a policy's rollout, see
:mod:`mgdata.engine.restart`) runs only the phases whose postcondition does not hold there, planning from
the arm's configuration in that state. A phase without a postcondition always runs.

Example::

    def phases(self, ctx):
        return [Phase("close_lid", self._close_lid(ctx), done="jar_closed"),
                Phase("carry", tuple(self.carry.segments(ctx)))]
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from mgdata.skeleton.segment import MotionSegment


@dataclass(frozen=True)
class Phase:
    """One named phase: its segments, in order, and its postcondition (a recipe proposition's name; ``None``:
    none, the phase always runs)."""

    name: str
    segments: tuple[MotionSegment, ...]
    done: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "segments", tuple(self.segments))


def remaining(phases: Sequence[Phase], holds: Callable[[str], bool]) -> list[Phase]:
    """The phases still to run: those whose postcondition does not hold (``holds(name)`` evaluates one)."""
    return [p for p in phases if p.done is None or not holds(p.done)]


def flatten(phases: Sequence[Phase]) -> list[MotionSegment]:
    """The segments of ``phases``, in order."""
    return [seg for phase in phases for seg in phase.segments]
