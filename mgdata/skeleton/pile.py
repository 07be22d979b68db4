"""A pile: the objects of a stack taken off one at a time, top first, and set down on top of each other on a
spot beside the pack (the stack family's destination pile), as segments and runtime targets.

The pile's spot is chosen from the live scene when the attempt starts (and checked by the initial-state gate):
spots on rings around the target ``pile_gap`` and more beyond the pack's footprint, at ``pile_bearings``
bearings (first those off the line the open hand spans along its closing axis when it grasps the target, then
those beside the pack as seen from the robot rather than in front of or behind it), inside the ``pile_x`` ×
``pile_y`` region (robot base frame, m; ``edge_pile_x`` × ``edge_pile_y`` for an edge-picked target), clear
of every other object and of the goal, where a straight-down hand reaches both the first object's place and
the pile's final height plus the pre-grasp standoff (IK, the arm ``pile_arm_clearance`` clear of everything,
the pack still standing), and the target keeps a reachable grasp (edge-picked: its push and a pinch) with the
whole stack piled there (checked in the planner's copy of the scene). On the nearest ring that has one, the
attempt's draw picks among the preferred ones. No spot is listed per task.

Each object is put on the pile upright, ``place_gap`` above its top, turned about the vertical by the first
of ``carry_yaws_deg`` the arm reaches. A skeleton declares ``PICK_AND_CARRY_KEYS + PILE_KEYS`` (+ its own)::

    pile = Pile("target", ("stack_0", "stack_1"))
    pile.choose_spot(ctx, ctx.variation.rng("pile"))
    segs = [seg for pick in picks for seg in pile.onto(ctx, pick)]   # picks: top first, tagged
    pose = pile.resolve(name, ctx, pick)                              # None: not a pile target of pick
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.motion import AllowedContacts, Pose
from mgdata.sim.geometry import LowestPoint
from mgdata.sim.robot import ROOT_BODY
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.skeleton import segment as s
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.edge_pick import EdgePick
from mgdata.skeleton.pick_and_carry import PickAndCarry
from mgdata.skeleton.poses import about_z, held_object, horizontal_unit, raised
from mgdata.skeleton.reach import reaches_down
from mgdata.skeleton.skeleton import Infeasible
from mgdata.skeleton.spots import Footprint, clear_of, footprints, in_box, ring
from mgdata.skeleton.whatif import planner_what_if
from mgdata.tasks.placer import footprint_radius
from mgdata.tasks.recipe_keys import Param, RecipeKeys

PILE_KEYS = RecipeKeys(params=(
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
))
"""The recipe ``[params]`` a pile reads besides its picks' (``PICK_AND_CARRY_KEYS``)."""


@dataclass(frozen=True)
class Pile:
    """The pile of ``stack`` beside ``target`` (see the module docstring).

    Attributes:
        target: the object the stack stands on (picked once the whole stack is piled).
        stack: the stacked objects, bottom first.
        edge: the target's edge pick if it is edge-picked (its push and a pinch must stay reachable beside
            the pile), else None (a grasp of it must).
    """

    target: str
    stack: tuple[str, ...]
    edge: EdgePick | None = None

    # -- segments and runtime targets ------------------------------------------------------------------------
    def choose_spot(self, ctx: Context, rng: np.random.Generator) -> None:
        """This attempt's spot (:meth:`spot`, the draw ``rng`` choosing); none ends it (``target_fail``)."""
        ctx.memo["pile_xy"] = self.spot(ctx, rng)
        if ctx.memo["pile_xy"] is None:
            raise AttemptFailed("target_fail", "no reachable spot for the pile beside the pack")

    @staticmethod
    def onto(ctx: Context, pick: PickAndCarry) -> list[s.MotionSegment]:
        """Pick one object off the stack, carry it over the pile, put it on top, release it, back off."""
        carry = s.free(pick.name("carry"), pick.name("over_pile"), gripper="close", attached=pick.obj,
                       speed=ctx.params["carry_speed"])
        return [*pick.pick_segments(ctx), carry,
                *pick.place_segments(pick.name("on_pile"), retreat_steps=ctx.params["release_steps"])]

    def resolve(self, name: str, ctx: Context, pick: PickAndCarry) -> Pose | None:
        """TCP pose putting the object ``pick`` holds on the pile (``on_pile``: ``place_gap`` above its top)
        or ``pile_approach`` above that (``over_pile``: the free carry goes there, around the stack, so that
        only a short straight line remains); None if ``name`` is neither (after ``pick``'s tag)."""
        if name not in (pick.name("over_pile"), pick.name("on_pile")):
            return None
        key = pick.name("pile_tcp")
        if name == pick.name("over_pile") or key not in ctx.memo:
            ctx.memo[key] = self._place_pose(pick.obj, ctx)
        place: Pose = ctx.memo[key]
        return place if name == pick.name("on_pile") else raised(place, ctx.param("pile_approach"))

    @staticmethod
    def _place_pose(obj: str, ctx: Context) -> Pose:
        """TCP pose putting the held ``obj`` upright on top of what is piled already (on the spot's table
        if nothing), turned about the vertical by the first of ``carry_yaws_deg`` the arm reaches."""
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

    # -- the spot --------------------------------------------------------------------------------------------
    def spot(self, ctx: Context, rng: np.random.Generator | None) -> np.ndarray | None:
        """The pile's centre (xy, m): see the module docstring. ``rng`` None: the first spot in ring order."""
        stack, scene = self.stack, ctx.scene
        target_xy = ctx.object_pose(self.target).pos[:2]
        r_pack = max(footprint_radius(ctx.task.object(n).model) for n in (self.target, *stack))
        r_pile = max(footprint_radius(ctx.task.object(n).model) for n in stack)
        gap = ctx.param("pile_gap")
        others = footprints(ctx, [o.name for o in ctx.task.objects
                                  if o.name in scene.objects and o.name not in (self.target, *stack)])
        if ctx.task.goal is not None:  # the target is carried there: keep the pile clear of it too
            others.append(Footprint(np.asarray(ctx.task.goal.pos[:2]),
                                    footprint_radius(ctx.task.object(self.target).model)))
        height = (sum(scene.object_model(n).size[2] for n in stack) + TABLE_TOP_Z
                  + ctx.param("reach_standoff"))
        radial = target_xy / max(float(np.linalg.norm(target_xy)), 1e-9)  # away from the robot's base
        target = ctx.object_pose(self.target).matrix()
        hand = [horizontal_unit((target @ g.matrix())[:3, 1]) for g in ctx.grasps[self.target]]
        low = TABLE_TOP_Z + min(scene.object_model(n).size[2] for n in stack) / 2.0
        region = "pile" if self.edge is None else "edge_pile"
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
                        and self.target_reachable_beside(ctx, spots[i])):
                    return spots[i]
        return None

    def target_reachable_beside(self, ctx: Context, xy: np.ndarray) -> bool:
        """Is a grasp of the target reachable with the whole stack piled at ``xy``? Checked in the planner's
        private copy of the scene, the stacked objects moved there (the live scene is not touched)."""
        piled, z = {}, TABLE_TOP_Z
        for name in reversed(self.stack):  # the top one goes first, at the bottom of the pile
            piled[name] = np.array([xy[0], xy[1], z])
            z += ctx.scene.object_model(name).size[2]
        if self.edge is not None:
            try:
                self.edge.feasibility(ctx, 1, moved=piled, clearance=ctx.param("pile_arm_clearance"))
            except Infeasible:
                return False
            return True
        with planner_what_if(ctx, objects=piled):
            return bool(PickAndCarry(self.target).reachable_grasps(ctx))
