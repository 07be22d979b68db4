"""Relocating an object that stands in the way: pick it, carry it in a straight line to a free spot, put it
down upright, release it and back off (its segments and runtime targets are tagged ``obj/``).

Example::

    move = Relocate("obstacle")
    segs = move.segments(ctx)                         # obstacle/open … obstacle/carry … obstacle/retreat
    pose = move.resolve(name, ctx, lambda: free_spot(ctx, "obstacle", rules, rng=rng, accept=ok))
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mgdata.skeleton import segment as s
from mgdata.skeleton.pick_and_carry import PickAndCarry

if TYPE_CHECKING:
    from mgdata.motion import Pose
    from mgdata.skeleton.context import Context


@dataclass(frozen=True)
class Relocate:
    """Move ``obj`` out of the way (see the module docstring); ``grasp_filter``: the approach hints its pick
    may use (empty: any)."""

    obj: str
    grasp_filter: tuple[str, ...] = ()

    @property
    def pick(self) -> PickAndCarry:
        """The tagged pick of ``obj`` (gate fact ``obj/grasps``)."""
        return PickAndCarry(self.obj, tag=f"{self.obj}/", grasp_filter=self.grasp_filter)

    def segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Pick (``open_steps`` …), carry straight above the spot (``carry_speed``), lower, release
        (``open_steps``), retreat."""
        pick, t = self.pick, f"{self.obj}/"
        return [*pick.pick_segments(ctx),
                s.linear(f"{t}carry", f"{t}over_spot", orientation="slerp", gripper="close",
                         attached=self.obj, speed=ctx.params["carry_speed"]),
                *pick.place_segments(f"{t}spot", retreat_steps=ctx.params["open_steps"])]

    def resolve(self, name: str, ctx: Context, spot: Callable[[], tuple[Pose, Pose]]) -> Pose | None:
        """The runtime target ``name`` if it is one of this relocation's (``spot()``: TCP poses above and at
        the spot), else None."""
        if name in (f"{self.obj}/over_spot", f"{self.obj}/spot"):
            return spot()[0 if name.endswith("over_spot") else 1]
        return self.pick.resolve(name, ctx)
