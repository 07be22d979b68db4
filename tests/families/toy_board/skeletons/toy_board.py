"""Toy board: push a chopping board lying flat over the table's back edge and lift it by the overhang.

All of it is the shared edge pick of the skeleton API (:mod:`mgdata.skeleton.edge_pick`); the numbers come
from the recipe's ``[params]``.
"""

from __future__ import annotations

from collections.abc import Sequence

from mgdata.motion import Pose
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.edge_pick import EDGE_PICK_KEYS, EdgePick
from mgdata.skeleton.pick_place import PICK_KEYS
from mgdata.skeleton.skeleton import FamilySkeleton, register

PICK = EdgePick("board")
"""Push and pick the instance named ``board`` (the recipe's layout role)."""


@register
class ToyBoardSkeleton(FamilySkeleton):
    """Lift the chopping board off the table."""

    name = "toy_board"
    recipe_keys = PICK_KEYS + EDGE_PICK_KEYS

    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        return [*PICK.segments(ctx), s.hold("hold", steps=60, gripper="close")]

    def resolve(self, name: str, ctx: Context) -> Pose:
        return PICK.resolve(name, ctx) or super().resolve(name, ctx)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        return PICK.feasibility(ctx, min_grasps)
