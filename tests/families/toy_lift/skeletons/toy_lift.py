"""Toy lift: pick a box up from the bare table and hold it in the goal sphere just above and beside it.

The motion: pre-grasp (free), descend onto the grasp (linear), close, lift, carry over the goal (free), lower
into it (linear), hold at rest. All of it is the shared pick-and-carry of the skeleton API; the numbers come
from the recipe's ``[variation]`` and ``[params]``.
"""

from __future__ import annotations

from collections.abc import Sequence

from mgdata.motion import Pose
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.skeleton import FamilySkeleton, register

CARRY = PickAndCarry("box")
"""Pick the instance named ``box`` (the recipe's layout role) and carry it into the goal."""


@register
class ToyLiftSkeleton(FamilySkeleton):
    """Pick up the box and put it into the goal sphere."""

    name = "toy_lift"
    recipe_keys = PICK_AND_CARRY_KEYS

    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        return CARRY.segments(ctx)

    def resolve(self, name: str, ctx: Context) -> Pose:
        return CARRY.resolve(name, ctx) or super().resolve(name, ctx)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        return CARRY.feasibility(ctx, min_grasps)
