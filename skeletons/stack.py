"""Stack: retrieve the bottom object from under a stack and carry it into the goal sphere (paper, "Stack").

The scene (``recipes/stack.toml``): a ``target`` on the table with ``stack_0`` (bottom) … ``stack_{n-1}``
(top) stacked on it. The motion, as the paper describes it: unstack one object at a time, top first, onto a
destination pile beside the pack (a top-down grasp shallow enough not to touch the object below, lift until it
clears everything, carry over the pile, lower it to ``place_gap`` above the pile's top, release, back off),
then pick the target (a box by its top, a tray by a pinch on one wall), lift it, carry it level in a straight
line into the goal and hold it there at rest. A chopping board lying flat, whose every grasp is an edge pinch,
is first pushed over the table's back edge and pinched there (:mod:`mgdata.skeleton.edge_pick`), then carried
likewise. Nothing in the stack or the target may fall or tip past 30° (the spec).

The pile's spot is chosen from the live scene when the attempt starts (and checked by the initial-state gate):
spots on rings around the target ``pile_gap`` and more beyond the pack's footprint, at ``pile_bearings``
bearings (first those off the line the open hand spans along its closing axis when it grasps the target, then
those beside the pack as seen from the robot rather than in front of or behind it), inside the ``pile_x`` ×
``pile_y`` region (robot base frame, m; ``edge_pile_x`` × ``edge_pile_y`` for a board), clear of every other
object and of the goal, where a straight-down hand reaches both the first object's place and the pile's final
height plus the pre-grasp standoff (IK, the arm ``pile_arm_clearance`` clear of everything, the pack still
standing), and the target keeps a reachable grasp (a board: its push and a pinch) with the whole stack piled
there (checked in the planner's copy of the scene). On the nearest ring that has one, the attempt's draw picks
among the preferred ones. No spot is listed per task.

Success also rejects a multi-grab: a pick (from its pre-grasp to the next pick's, or to the end for the
target) that moved any object other than the picked one more than ``multi_grab_distance`` in xy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.grasps.edge import needs_overhang
from mgdata.motion import AllowedContacts, Pose
from mgdata.sim.geometry import LowestPoint
from mgdata.sim.robot import ROOT_BODY
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.skeleton import segment as s
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.edge_pick import EDGE_PICK_KEYS, EdgePick
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.poses import about_z, held_object, horizontal_unit, raised
from mgdata.skeleton.reach import reaches_down
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Param, RecipeKeys, register
from mgdata.skeleton.spots import Footprint, clear_of, footprints, in_box, ring
from mgdata.skeleton.whatif import planner_what_if
from mgdata.tasks.placer import footprint_radius

TARGET = "target"
STACK = "stack_"
TOP_DOWN = ("top_down",)
EDGE = EdgePick(TARGET)
"""The target's pick when it is edge-picked (:func:`_edge_picked`)."""


@register
class StackSkeleton(FamilySkeleton):
    """The stack family's demonstration (see the module docstring)."""

    name = "stack"
    recipe_keys = PICK_AND_CARRY_KEYS + EDGE_PICK_KEYS + RecipeKeys(params=(
        Param("pile_gap", float, "m between the pack's footprint and the pile's, edge to edge", 0.0, 0.3),
        Param("pile_rings", int, "rings of pile spots tried around the target", 1, 10),
        Param("pile_ring_step", float, "m between two rings of pile spots", 0.005, 0.2),
        Param("pile_bearings", int, "pile spots per ring (evenly spaced bearings)", 1, 72),
        Param("pile_x", tuple, "x range (m, robot base frame) the pile's centre stays in", -1.0, 1.0),
        Param("pile_y", tuple, "y range (m, robot base frame) the pile's centre stays in", -1.0, 1.0),
        Param("edge_pile_x", tuple, "x range (m) the pile's centre stays in when the target is edge-picked",
              -1.0, 1.0),
        Param("edge_pile_y", tuple, "y range (m) the pile's centre stays in when the target is edge-picked",
              -1.0, 1.0),
        Param("pile_approach", float, "m above its place pose from which an object is lowered onto the pile",
              0.0, 0.3),
        Param("place_gap", float, "m above the pile's top at which an object is released", 0.0, 0.05),
        Param("release_steps", int, "control steps to open the gripper on the pile", 1, 200),
        Param("pile_arm_clearance", float, "m the arm keeps from everything when the pile spot is tested",
              0.0, 0.1),
        Param("multi_grab_distance", float, "m in xy another object may move during a pick", 0.005, 0.5),
    ))

    # -- segments ----------------------------------------------------------------------------------------
    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        ctx.memo["pile_xy"] = self._pile_spot(ctx, ctx.variation.rng("pile"))
        if ctx.memo["pile_xy"] is None:
            raise AttemptFailed("target_fail", "no reachable spot for the pile beside the pack")
        segs: list[s.MotionSegment] = []
        for pick in self._unstack(ctx):
            segs += self._onto_pile(ctx, pick)
        if _edge_picked(ctx):
            return [*segs, *EDGE.segments(ctx), *self._target().carry_segments(ctx)]
        return [*segs, *self._target().segments(ctx)]

    @staticmethod
    def _onto_pile(ctx: Context, pick: PickAndCarry) -> list[s.MotionSegment]:
        """Pick one object off the stack, carry it over the pile, put it on top, release it, back off."""
        carry = s.free(pick.name("carry"), pick.name("over_pile"), gripper="close", attached=pick.obj,
                       speed=ctx.params["carry_speed"])
        return [*pick.pick_segments(ctx), carry,
                *pick.place_segments(pick.name("on_pile"), retreat_steps=ctx.params["release_steps"])]

    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.endswith("pre_grasp") or name == "pre_push":
            self._start_pick(ctx, name)
        for pick in self._unstack(ctx):
            if name in (pick.name("over_pile"), pick.name("on_pile")):
                return self._pile_target(pick, name, ctx)
            pose = pick.resolve(name, ctx)
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
        if self._pile_spot(ctx, None) is None:
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

    # -- the pile ----------------------------------------------------------------------------------------
    def _pile_target(self, pick: PickAndCarry, name: str, ctx: Context) -> Pose:
        """TCP pose putting the held object on the pile (``on_pile``: ``place_gap`` above its top) or
        ``pile_approach`` above that (``over_pile``: the free carry goes there, around the stack, so that
        only a short straight line remains), the object upright and turned about the vertical by the first
        of ``carry_yaws_deg`` the arm reaches."""
        key = pick.name("pile_tcp")
        if name == pick.name("over_pile") or key not in ctx.memo:
            ctx.memo[key] = self._place_pose(pick.obj, ctx)
        place: Pose = ctx.memo[key]
        return place if name == pick.name("on_pile") else raised(place, ctx.param("pile_approach"))

    @staticmethod
    def _place_pose(obj: str, ctx: Context) -> Pose:
        scene = ctx.scene
        piled = [n for n in ctx.memo.setdefault("piled", []) if n != obj]
        ctx.memo["piled"] = [*piled, obj]
        if piled:
            xy = ctx.object_pose(piled[-1]).pos[:2]
            base = max(scene.object_pose(n)[0][2] + scene.object_model(n).size[2] for n in piled)
        else:
            xy, base = np.asarray(ctx.memo["pile_xy"]), TABLE_TOP_Z
        pose, held = ctx.object_pose(obj), held_object(ctx, obj)
        low = LowestPoint(scene.model, scene.object_geom_ids(obj))(scene.data)
        z = pose.pos[2] + (base + ctx.param("place_gap") - low)
        rng = ctx.variation.rng(f"pile/{obj}")

        def on_pile(yaw: float) -> Pose:
            turned = Pose(np.zeros(3), about_z(math.radians(yaw))) @ Pose(np.zeros(3), pose.quat)
            return held.tcp_for(Pose(np.array([xy[0], xy[1], z]), turned.quat))

        return first_reachable(map(on_pile, ctx.param("carry_yaws_deg")), lambda target: ctx.planner.ik(
            target, ctx.q_cmd, rng, collision_free=True, attached=held.attachment,
            allowed=AllowedContacts(((ROOT_BODY, obj),)))).found_or_first

    def _pile_spot(self, ctx: Context, rng: np.random.Generator | None) -> np.ndarray | None:
        """The pile's centre (xy, m): see the module docstring. ``rng`` None: the first spot in ring order."""
        stack, scene = _stack(ctx), ctx.scene
        target_xy = ctx.object_pose(TARGET).pos[:2]
        r_pack = max(footprint_radius(ctx.task.object(n).model) for n in (TARGET, *stack))
        r_pile = max(footprint_radius(ctx.task.object(n).model) for n in stack)
        gap = ctx.param("pile_gap")
        others = footprints(ctx, [n for n in _objects(ctx) if n not in (TARGET, *stack)])
        if ctx.task.goal is not None:  # the target is carried there: keep the pile clear of it too
            others.append(Footprint(np.asarray(ctx.task.goal.pos[:2]),
                                    footprint_radius(ctx.task.object(TARGET).model)))
        height = (sum(scene.object_model(n).size[2] for n in stack) + TABLE_TOP_Z
                  + ctx.param("reach_standoff"))
        radial = target_xy / max(float(np.linalg.norm(target_xy)), 1e-9)  # away from the robot's base
        target = ctx.object_pose(TARGET).matrix()
        hand = [horizontal_unit((target @ g.matrix())[:3, 1]) for g in ctx.grasps[TARGET]]
        low = TABLE_TOP_Z + min(scene.object_model(n).size[2] for n in stack) / 2.0
        region = "edge_pile" if _edge_picked(ctx) else "pile"
        box_x, box_y = ctx.param(f"{region}_x"), ctx.param(f"{region}_y")
        for k in range(ctx.param("pile_rings")):
            d = r_pack + r_pile + gap + k * ctx.param("pile_ring_step")
            spots = [xy for xy in ring(target_xy, d, ctx.param("pile_bearings"))
                     if clear_of(xy, r_pile, others, gap) and in_box(xy, box_x, box_y)]
            order = list(range(len(spots)))
            if rng is not None:
                rng.shuffle(order)

            def along(i: int, axis: np.ndarray, d: float = d, spots: list[np.ndarray] = spots) -> bool:
                return abs(float(np.dot(spots[i] - target_xy, axis))) > 0.5 * d

            # off the line the hand spans when it grasps the target (20 cm along its closing axis) first, then
            # beside the pack: a pile in front of it is in the arm's way to the target, one behind it puts
            # the forearm over the stack while placing
            order.sort(key=lambda i: (any(along(i, c) for c in hand), along(i, radial)))
            for i in order:
                if (all(reaches_down(ctx, np.array([*spots[i], z]), ctx.task_rng("pile_reach_down"),
                                     clearance=ctx.param("pile_arm_clearance")) for z in (low, height))
                        and self._target_reachable_beside(ctx, spots[i])):
                    return spots[i]
        return None

    @staticmethod
    def _target_reachable_beside(ctx: Context, xy: np.ndarray) -> bool:
        """Is a grasp of the target reachable with the whole stack piled at ``xy``? Checked in the planner's
        private copy of the scene, the stacked objects moved there (the live scene is not touched)."""
        piled, z = {}, TABLE_TOP_Z
        for name in reversed(_stack(ctx)):  # the top one goes first, at the bottom of the pile
            piled[name] = np.array([xy[0], xy[1], z])
            z += ctx.scene.object_model(name).size[2]
        if _edge_picked(ctx):
            try:
                EDGE.feasibility(ctx, 1, moved=piled, clearance=ctx.param("pile_arm_clearance"))
            except Infeasible:
                return False
            return True
        with planner_what_if(ctx, objects=piled):
            return bool(PickAndCarry(TARGET).reachable_grasps(ctx))


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
