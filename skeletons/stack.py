"""Stack: retrieve the bottom object from under a stack and carry it into the goal sphere (paper, "Stack").

The scene (``recipes/stack.toml``): a ``target`` on the table with ``stack_0`` (bottom) … ``stack_{n-1}``
(top) stacked on it. The motion, as the paper describes it: unstack one object at a time, top first, onto a
destination pile beside the pack (a top-down grasp shallow enough not to touch the object below, lift until it
clears everything, carry over the pile, lower it to ``place_gap`` above the pile's top, release, back off),
then pick the target (a box by its top, a tray by a pinch on one wall), lift it, carry it level in a straight
line into the goal and hold it there at rest. A chopping board lying flat, whose every grasp is an edge pinch,
is first pushed over the table's back edge and pinched there (:mod:`mgdata.skeleton.edge_pick`), then carried
likewise. Nothing in the stack or the target may fall or tip past 30° (the spec).

The pile's spot is chosen from the live scene when the attempt starts, beside the pack where the arm reaches
it and the target stays reachable (the rules: :mod:`mgdata.skeleton.pile`); no spot is listed per task.

Success also rejects a multi-grab: a pick (from its pre-grasp to the next pick's, or to the end for the
target) that moved any object other than the picked one more than ``multi_grab_distance`` in xy.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mgdata.grasps.edge import needs_overhang
from mgdata.motion import Pose
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.edge_pick import EDGE_PICK_KEYS, EdgePick
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.pile import PILE_KEYS, Pile
from mgdata.skeleton.poses import raised
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Param, RecipeKeys, register
from mgdata.skeleton.whatif import planner_what_if

TARGET = "target"
STACK = "stack_"
TOP_DOWN = ("top_down",)
EDGE = EdgePick(TARGET)
"""The target's pick when it is edge-picked (:func:`_edge_picked`)."""


@register
class StackSkeleton(FamilySkeleton):
    """The stack family's demonstration (see the module docstring)."""

    name = "stack"
    recipe_keys = PICK_AND_CARRY_KEYS + EDGE_PICK_KEYS + PILE_KEYS + RecipeKeys(params=(
        Param("multi_grab_distance", float, "m in xy another object may move during a pick", 0.005, 0.5),
    ))

    # -- segments ----------------------------------------------------------------------------------------
    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        pile = _pile(ctx)
        pile.choose_spot(ctx, ctx.variation.rng("pile"))
        segs = [seg for pick in self._unstack(ctx) for seg in pile.onto(ctx, pick)]
        if _edge_picked(ctx):
            return [*segs, *EDGE.segments(ctx), *self._target().carry_segments(ctx)]
        return [*segs, *self._target().segments(ctx)]

    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.endswith("pre_grasp") or name == "pre_push":
            self._start_pick(ctx, name)
        pile = _pile(ctx)
        for pick in self._unstack(ctx):
            pose = pile.resolve(name, ctx, pick) or pick.resolve(name, ctx)
            if pose is not None:
                return pose
        if _edge_picked(ctx):  # the edge pick records the episode's grasp itself
            return EDGE.resolve(name, ctx) or self._target().resolve(name, ctx) or super().resolve(name, ctx)
        pose = self._target().resolve(name, ctx)
        if pose is None:
            return super().resolve(name, ctx)
        ctx.memo["grasp_id"] = ctx.memo[self._target().name("grasp")].id  # the episode's grasp: the target's
        return pose

    def success_extra(self, ctx: Context) -> bool:
        return not ctx.memo.get("multi_grab") and not self._moved_others(ctx)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """Every stacked object has a reachable shallow top-down grasp (the objects above it allowed to be
        touched: they are gone by then), the target has ``min_grasps`` reachable grasps and reaches the goal
        (the stack allowed likewise), and a pile spot exists."""
        stack = _stack(ctx)
        for i, obj in enumerate(stack):
            if not PickAndCarry(obj, riders=stack[i + 1:], grasp_filter=TOP_DOWN).reachable_grasps(ctx):
                raise Infeasible("reach.stack", f"no top-down grasp of {obj} is reachable")
        facts = (self._edge_feasibility(ctx, min_grasps) if _edge_picked(ctx)
                 else PickAndCarry(TARGET, riders=stack).feasibility(ctx, min_grasps))
        if _pile(ctx).spot(ctx, None) is None:
            raise Infeasible("reach.pile", "no reachable pile spot beside the pack clear of the goal")
        return facts

    def _edge_feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """An edge-picked target: reachable pinches and push (the stack already taken off, out of the way)
        and, from the first pinch, the goal reachable holding it."""
        facts = EDGE.feasibility(ctx, min_grasps, moved=_stack_away(ctx))
        grasp = next(g for g in ctx.grasps[TARGET] if g.id == facts["grasps"][0])
        pushed = EDGE.pushed(ctx, grasp)
        tcp, lift = Pose.from_matrix(pushed.matrix() @ grasp.matrix()), ctx.param("edge_lift")
        with planner_what_if(ctx, objects=_stack_away(ctx)):
            self._target().require_goal(ctx, raised(tcp, lift), raised(pushed, lift))
        return facts

    # -- the picks ---------------------------------------------------------------------------------------
    @staticmethod
    def _unstack(ctx: Context) -> list[PickAndCarry]:
        """One tagged pick per stacked object, top first (``s0`` picks the top one)."""
        stack = _stack(ctx)
        below = dict(zip(stack, (TARGET, *stack[:-1]), strict=True))
        return [PickAndCarry(obj, grasp_filter=TOP_DOWN, tag=f"s{k}/", support=below[obj])
                for k, obj in enumerate(reversed(stack))]

    @staticmethod
    def _target() -> PickAndCarry:
        """The target's pick, tagged too: its grasp is chosen among those reachable from where the arm is
        after the unstacking (from its start pose the gate found grasps; IK from above the pile may not reach
        the same roll). It is carried level in a straight line: a tray pinched at one end turned 20–27° in the
        pinch when a free carry set off, level it stays within 3°."""
        return PickAndCarry(TARGET, tag=f"{TARGET}/", level=True)

    def _start_pick(self, ctx: Context, name: str) -> None:
        """A pick starts: judge the one before (multi-grab), then remember where everything is."""
        if self._moved_others(ctx):
            ctx.memo["multi_grab"] = True
        ctx.memo["picking"] = next((p.obj for p in self._unstack(ctx) if p.name("pre_grasp") == name), TARGET)
        ctx.memo["pick_start"] = {n: ctx.object_pose(n).pos[:2].copy() for n in _objects(ctx)}

    @staticmethod
    def _moved_others(ctx: Context) -> bool:
        start = ctx.memo.get("pick_start")
        if start is None:
            return False
        limit = ctx.param("multi_grab_distance")
        return any(float(np.linalg.norm(ctx.object_pose(n).pos[:2] - xy)) > limit
                   for n, xy in start.items() if n != ctx.memo["picking"])


def _pile(ctx: Context) -> Pile:
    """The destination pile of the stack beside the target (:mod:`mgdata.skeleton.pile`)."""
    return Pile(TARGET, _stack(ctx), EDGE if _edge_picked(ctx) else None)


def _edge_picked(ctx: Context) -> bool:
    """Is the target picked by an edge pinch (pushed over the table's back edge first)? A chopping board
    lying flat: every valid grasp of it needs an overhang."""
    grasps = ctx.grasps.get(TARGET, ())
    return bool(grasps) and all(needs_overhang(g) for g in grasps)


def _stack_away(ctx: Context) -> dict[str, np.ndarray]:
    """The stacked objects out of the arm's way (for the target's checks before they are unstacked): far
    below the table."""
    return {name: np.array([0.0, 0.0, -1.0 - k]) for k, name in enumerate(_stack(ctx))}


def _objects(ctx: Context) -> list[str]:
    return [o.name for o in ctx.task.objects if o.name in ctx.scene.objects]


def _stack(ctx: Context) -> tuple[str, ...]:
    """The stacked objects, bottom first (``stack_0``, ``stack_1`` …: the layout places each on the one
    before, in the task's object order)."""
    return tuple(o.name for o in ctx.task.objects if o.name.startswith(STACK))
