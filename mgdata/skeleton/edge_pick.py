"""Edge pick: slide a flat object (a chopping board, a plate) over the table's back edge with the open hand,
then pick it by a pinch of the overhang (:mod:`mgdata.grasps.edge`). Honest physics: the push is the fingers'
contact, the hold their friction.

The motion: open; above the push's start (free), ``push_clearance`` beyond the object's far side, the hand
pointing down with its fingers spread along the edge; down to the fingertips ``push_tip_height`` above the
table (linear); push towards the back edge (world -X) in a straight line as far as the chosen pinch's
fingertips lack to clear the table's edge by ``edge_clearance``, measured on the live object
(:func:`~mgdata.grasps.edge.shortfall`); let the arm settle; push again by what the object still lacks (the
pushing arm lags its command; a push of less than ``push_tolerance`` stays put); rise; then the pick of
:class:`~mgdata.skeleton.pick_place.PickPlace`: pre-grasp ``push_standoff`` beyond the edge (free),
approach, settle, close, lift straight up by ``edge_lift``. The approach aims where the arm comes to rest at
the pinch (:mod:`mgdata.grasps.rest`): aimed at the pinch itself the arm rested ~5 mm low, the upper finger
met the board first and pressed it up to 5 mm into the table's edge.

The pinch is one of the object's valid edge grasps (``needs_overhang``) that comes in from behind the back
edge and that the arm reaches once the object is pushed out (:meth:`EdgePick.feasibility`, the
initial-state gate's check, records them as the fact ``grasps``); the draw picks among them.

A skeleton declares ``PICK_KEYS + EDGE_PICK_KEYS`` (or ``PICK_AND_CARRY_KEYS + EDGE_PICK_KEYS``, + its own)
and plugs it in::

    PICK = EdgePick("board")

    def segments(self, ctx):
        return PICK.segments(ctx)

    def resolve(self, name, ctx):
        return PICK.resolve(name, ctx) or super().resolve(name, ctx)

    def feasibility(self, ctx, min_grasps):
        return PICK.feasibility(ctx, min_grasps)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mgdata.grasps.db import Grasp
from mgdata.grasps.edge import faces_the_back_edge, needs_overhang, push_start, shortfall
from mgdata.grasps.rest import resting_target
from mgdata.motion import AllowedContacts, MotionFailure, Pose
from mgdata.sim.robot import HOME_Q, ROOT_BODY
from mgdata.skeleton import segment as s
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.grasp_choice import choose_grasp
from mgdata.skeleton.pick_place import PickPlace
from mgdata.skeleton.poses import backed_off, raised
from mgdata.skeleton.skeleton import Infeasible
from mgdata.skeleton.whatif import planner_what_if
from mgdata.tasks.recipe_keys import Param, RecipeKeys

EDGE_PICK_KEYS = RecipeKeys(params=(
    Param("push_tip_height", float, "m above the table: the pushing fingertips", 0.002, 0.03),
    Param("push_clearance", float, "m beyond the object's far side where the push starts", 0.005, 0.1),
    Param("push_standoff", float, "m above the push's start, and back along the pinch's approach for its "
          "pre-grasp", 0.03, 0.3),
    Param("push_settle_steps", int, "control steps the arm settles after a push", 1, 200),
    Param("push_tolerance", float, "m the object may still lack after the first push without a second",
          0.0, 0.02),
    Param("edge_clearance", float, "m the pinch's fingertips clear the table's edge", 0.0, 0.03),
    Param("edge_lift", float, "m the pinched object is lifted", 0.02, 0.3),
))
"""The recipe ``[params]`` an edge pick reads besides its pick's (``PICK_KEYS``, which ``PICK_AND_CARRY_KEYS``
includes)."""

@dataclass(frozen=True)
class EdgePick:
    """Push ``obj`` over the table's back edge and pick it by an edge pinch (see the module docstring)."""

    obj: str

    @property
    def _pick(self) -> PickPlace:
        return PickPlace(self.obj)

    def segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Open, the push (to the object's overhang) and the pick, as segments."""
        p = ctx.params
        push = (("hand", self.obj), (self.obj, "table"))
        return [
            s.gripper("push_open", "open", steps=p["open_steps"]),
            s.free("pre_push", "pre_push"),
            s.linear("push_start", "push_start"),
            s.linear("push", "push", allow=push),
            s.hold("push_settle", steps=p["push_settle_steps"]),
            s.linear("push_more", "push_more", allow=push),
            s.hold("push_more_settle", steps=p["push_settle_steps"]),
            s.linear("push_rise", "push_rise", allow=push),
            *self._pick.pick(p),
        ]

    def resolve(self, name: str, ctx: Context) -> Pose | None:
        """The TCP pose of runtime target ``name`` (``pre_push``, ``push_start``, ``push``, ``push_more``,
        ``push_rise``, then the pick's ``pre_grasp``, ``grasp``, ``lift``), from the live state, or None if it
        is not one."""
        p = ctx.params
        if name == "pre_push":
            grasp = choose_grasp(ctx, self.obj, "grasps", lambda: self.reachable(ctx),
                                 none=f"no edge pinch of {self.obj} is reachable over the table's back edge")
            ctx.memo["grasp"], ctx.memo["grasp_id"] = grasp, grasp.id
            start = push_start(ctx.scene, self.obj, p["push_tip_height"], p["push_clearance"])
            ctx.memo["push_start"] = start
            return raised(start, p["push_standoff"])
        if name == "push_start":
            return ctx.memo["push_start"]
        if name in ("push", "push_more"):
            lacking = shortfall(self._grasp_world(ctx), p["edge_clearance"])
            if name == "push_more" and lacking < p["push_tolerance"]:
                lacking = 0.0
            back = p["push_clearance"] if name == "push" else 0.0
            here = ctx.commanded_tcp()
            return Pose(here.pos - np.array([max(lacking, 0.0) + back, 0.0, 0.0]), here.quat)
        if name == "push_rise":
            return raised(ctx.commanded_tcp(), p["push_standoff"])
        if name in ("pre_grasp", "grasp"):
            pose = Pose.from_matrix(self._grasp_world(ctx))
            rested = resting_target(ctx.planner, ctx.scene.model, pose, (ctx.q_cmd, HOME_Q),
                                    ctx.variation.rng("rest/edge_grasp"))
            if name == "grasp":
                return rested
            return self._pre_from_home(ctx, name, (backed_off(rested, p["push_standoff"]),
                                                   backed_off(pose, p["push_standoff"])))
        if name == "lift":
            return raised(ctx.commanded_tcp(), p["edge_lift"])
        return None

    @staticmethod
    def _pre_from_home(ctx: Context, name: str, poses: tuple[Pose, Pose]) -> Pose:
        """The first of ``poses`` (the pre-grasp in line with where the arm rests at the pinch, then in line
        with the pinch itself: stretched out behind the base the first is at times just out of reach) with
        a collision-free IK solution from the home posture, which seeds the attempt's IK for ``name``, as
        :meth:`reachable` found it: from where the push leaves the arm, a pinch with the hand rolled half a
        turn is often out of the solver's reach (``ik_fail``, residual 0.3 m). The last where neither has."""
        rng = ctx.task_rng("edge_reach")
        search = first_reachable(poses, lambda pose: ctx.planner.ik(pose, HOME_Q, rng, collision_free=True))
        search.seed(ctx, name)
        return poses[-1] if search.found is None else search.found

    def _grasp_world(self, ctx: Context) -> np.ndarray:
        grasp: Grasp = ctx.memo["grasp"]
        return ctx.object_pose(self.obj).matrix() @ grasp.matrix()

    def reachable(self, ctx: Context, moved: Mapping[str, Pose | np.ndarray] | None = None
                  ) -> tuple[Grasp, ...]:
        """The object's edge pinches that come in from behind the table's back edge and whose pre-grasp and
        grasp the arm reaches (collision-free, in the planner's copy of the scene) with the object slid as
        far as each needs, from the state in ``ctx`` with a task-derived seed; ``moved``: other objects
        elsewhere in that copy (a stack already taken off the object)."""
        p, planner, rng = ctx.params, ctx.planner, ctx.task_rng("edge_reach")
        touch = AllowedContacts((("hand", self.obj),))
        here = ctx.object_pose(self.obj)
        out = []
        for grasp in ctx.grasps.get(self.obj, ()):
            world = here.matrix() @ grasp.matrix()
            if not needs_overhang(grasp) or not faces_the_back_edge(world):
                continue
            out_there = self.pushed(ctx, grasp)
            pose = Pose.from_matrix(out_there.matrix() @ grasp.matrix())
            with planner_what_if(ctx, objects={**(moved or {}), self.obj: out_there}):
                try:
                    q_pre = planner.ik(backed_off(pose, p["push_standoff"]), ctx.q_cmd, rng,
                                       collision_free=True)
                    planner.ik(pose, q_pre, rng, collision_free=True, allowed=touch)
                except MotionFailure:
                    continue
            out.append(grasp)
        return tuple(out)

    def pushed(self, ctx: Context, grasp: Grasp) -> Pose:
        """Where the object lies once pushed from where it is now as far as ``grasp`` needs."""
        here = ctx.object_pose(self.obj)
        lacking = max(shortfall(here.matrix() @ grasp.matrix(), ctx.param("edge_clearance")), 0.0)
        return Pose(here.pos - np.array([lacking, 0.0, 0.0]), here.quat)

    def feasibility(self, ctx: Context, min_grasps: int, moved: Mapping[str, Pose | np.ndarray] | None = None,
                    clearance: float = 0.0) -> dict[str, object]:
        """The initial-state gate's check: at least ``min_grasps`` reachable edge pinches, and the push's
        start reachable from above, in a collision-free straight line down that keeps the arm ``clearance`` m
        from everything but the table and the object (``moved`` as in :meth:`reachable`).
        Returns ``{"grasps": ids}``; the arm configuration found above the push's start seeds the attempt's
        IK for ``pre_push`` (``ctx.q_hints``), so that a check made when the attempt starts is the line it
        runs."""
        reachable = self.reachable(ctx, moved)
        if len(reachable) < max(min_grasps, 1):
            raise Infeasible("reach.grasps", f"{len(reachable)} edge pinches of {self.obj} are reachable "
                                             f"over the table's back edge (needs {min_grasps})")
        p = ctx.params
        start = push_start(ctx.scene, self.obj, p["push_tip_height"], p["push_clearance"])
        try:
            with planner_what_if(ctx, objects=moved):
                rng = ctx.task_rng("edge_push")
                above = ctx.planner.ik(raised(start, p["push_standoff"]), ctx.q_cmd, rng, collision_free=True)
                line = ctx.planner.line(above, start, rng)
                if clearance > 0.0:
                    self._keeps_clear(ctx, line.q, clearance)
            ctx.q_hints["pre_push"] = above
        except MotionFailure as fail:
            raise Infeasible("reach.push", f"the push of {self.obj} cannot start ({fail.reason})") from fail
        return {"grasps": tuple(g.id for g in reachable)}

    def _keeps_clear(self, ctx: Context, path: np.ndarray, clearance: float) -> None:
        """Raise ``plan_fail`` unless the arm at every configuration of ``path`` keeps ``clearance`` m from
        everything but the table and the object."""
        checker = ctx.planner.checker
        checker.configure(AllowedContacts(((ROOT_BODY, "table"), (ROOT_BODY, self.obj))), None, clearance)
        bad = next((q for q in path if not checker.valid(q)), None)
        if bad is not None:
            raise MotionFailure("plan_fail", f"the way down to the push comes within {clearance:g} m of "
                                             f"something ({checker.explain(bad)})")
