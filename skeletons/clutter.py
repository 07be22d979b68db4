"""Clutter: pick the target out of dense tableware and carry it into the goal sphere (paper, "Clutter").

The motion, as the paper describes it: pre-grasp (free), descend onto the grasp (linear), close, lift until
the target clears the tallest object around it, transport over the goal (free), lower it into the goal
(linear) and hold it there at rest. Nothing else on the table may fall or tip (the spec).

Two recipes share this skeleton:

* ``clutter_dry``: the role ``target`` is a cup, mug, bottle, box … among ``obstacle_*`` tableware;
* ``clutter_liquid``: the role ``container`` holds liquid particles (``liquid``); it is side-grasped (a
  finger never dips into the liquid), carried level in a straight line at the clearance height and slowly
  (``carry_speed``), so that it stays within its 15° tilt and nothing spills.

Numbers come from the recipe: ``[variation]`` draws and ``[params]`` tunables (all pick-and-carry's).
"""

from __future__ import annotations

from collections.abc import Sequence

from mgdata.motion import Pose
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.skeleton import FamilySkeleton, register

PICKED = ("target", "container")
"""The role picked: ``target`` (dry) or ``container`` (liquid)."""


@register
class ClutterSkeleton(FamilySkeleton):
    """The clutter families' demonstration (see the module docstring)."""

    name = "clutter"
    recipe_keys = PICK_AND_CARRY_KEYS

    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        return self._carry(ctx).segments(ctx)

    def resolve(self, name: str, ctx: Context) -> Pose:
        return self._carry(ctx).resolve(name, ctx) or super().resolve(name, ctx)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        return self._carry(ctx).feasibility(ctx, min_grasps)

    @staticmethod
    def _carry(ctx: Context) -> PickAndCarry:
        names = [o.name for o in ctx.task.objects]
        picked = next(n for n in PICKED if n in names)
        liquids = tuple(n for n in names if n in ctx.scene.liquids)
        if liquids:
            return PickAndCarry(picked, riders=liquids, grasp_filter=("side",), level=True)
        return PickAndCarry(picked)
