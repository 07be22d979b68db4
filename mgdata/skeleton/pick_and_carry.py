"""Pick-and-carry: the motion most families share, as segments and runtime targets a skeleton plugs in.

The paper's pick: open, move to a pre-grasp pose ``grasp_standoff`` back along the grasp's approach axis
(free), approach it (linear), let the arm settle, close, lift until the lowest point of the held object is
``lift_margin`` above the tallest other object (at least ``lift_height``), carry it (free, or ``level`` in a
straight line; slowed to ``carry_speed``) over the goal, lower it into the goal (linear) and hold it there.
Grasps come from the grasp DB, round-robin over the task's reachable valid grasps
(:meth:`PickAndCarry.reachable_grasps`, also the initial-state gate's check), or, with ``grasp_cycle`` k > 0,
over the k most natural of them (the arm at the pre-grasp nearest its home posture, reached on that same
branch by every draw: one grasp and one arm configuration per layout at k = 1, data a policy can imitate).
Objects riding inside the held one (food in a jar, liquid in a cup) are the segments' ``riders``. For
families that put an object down: :meth:`PickAndCarry.place_segments` (lower, release, retreat).

A skeleton declares the keys it reads as ``PICK_AND_CARRY_KEYS`` + its own::

    recipe_keys = PICK_AND_CARRY_KEYS + RecipeKeys(params=(...), variation=(...))

    def segments(self, ctx):
        return self.carry.segments(ctx)

    def resolve(self, name, ctx):
        return self.carry.resolve(name, ctx) or super().resolve(name, ctx)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.grasps.db import Grasp
from mgdata.motion import NO_CONTACTS, AllowedContacts, MotionFailure, Pose
from mgdata.sim.geometry import LowestPoint
from mgdata.sim.robot import HOME_Q, ROOT_BODY
from mgdata.skeleton import segment as s
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.grasp_choice import usable_grasps
from mgdata.skeleton.pick_place import PICK_KEYS, PickPlace
from mgdata.skeleton.poses import about_z, backed_off, held_object, raised
from mgdata.skeleton.skeleton import Infeasible
from mgdata.tasks.recipe_keys import Knob, Param, RecipeKeys

GRASP_CYCLE = Param("grasp_cycle", int, "reachable grasps the draws cycle through, most natural first "
                    "(0: all, in the grasp DB's order)", 0, 1000, default=0)
"""Optional: a recipe read without its skeleton's check (``load_recipe``) lacks it and gets the default."""

RIM_CLEARANCE = Param("rim_clearance", float, "m the raised grasp keeps the TCP below the picked object's "
                      "top (caps the draw's grasp_height, so side-grasping pads press the wall, not the rim "
                      "edge; 0: no cap)", 0.0, 0.1, default=0.0)
"""Optional, like :data:`GRASP_CYCLE`: recipes without it keep their grasps and their datasets' bytes."""

PICK_AND_CARRY_KEYS = PICK_KEYS + RecipeKeys(
    params=(
        Param("lift_margin", float, "m the held object's lowest point clears the tallest other object",
              0.0, 0.3),
        Param("carry_speed", float, "fraction of the planned speed while carrying", 0.01, 1.0),
        Param("goal_approach", float, "m above the goal from which the object is lowered into it", 0.0, 0.3),
        Param("goal_hold_steps", int, "control steps holding the object still in the goal", 1, 2000),
        Param("grasp_margin", float, "rad every joint of a reachable grasp keeps from its limits", 0.0, 1.0),
        Param("grasp_clearance", float, "m a reachable grasp keeps the arm from all but the object",
              0.0, 0.05),
        Param("reach_standoff", float, "m pre-grasp standoff used to test which grasps are reachable",
              0.0, 0.3),
        GRASP_CYCLE,
        RIM_CLEARANCE,
        Param("carry_yaws_deg", tuple, "turns of the object about the vertical tried at the goal (deg)",
              -180.0, 180.0),
    ),
    variation=(
        Knob("grasp_standoff", "m back along the approach axis for the pre-grasp pose", 0.0, 0.3),
        Knob("grasp_height", "m offset of the grasp along the object's vertical axis", -0.05, 0.05),
        Knob("lift_height", "m the object is lifted at least before carrying", 0.0, 0.3),
        Knob("goal_dx", "m offset of the carried object's centre from the goal centre along x", -0.05, 0.05),
        Knob("goal_dy", "m offset of the carried object's centre from the goal centre along y", -0.05, 0.05),
    ),
)
"""The recipe keys pick-and-carry reads; a skeleton adds them to its own ``recipe_keys``."""

TARGETS = ("pre_grasp", "grasp", "lift", "over_goal", "goal", "retreat")


@dataclass(frozen=True)
class PickAndCarry:
    """Pick ``obj`` (an instance name) with a DB grasp and carry it into the task's goal sphere.

    Attributes:
        obj: the object picked.
        riders: instances riding inside it (carried along, never obstacles while it is held).
        grasp_filter: approach hints allowed (``("side",)`` for side grasps only); empty = any.
        level: carry in a straight line at the lift height, the object upright all the way (only turned
            about the vertical), instead of a free joint-space path (liquids).
        tag: prefix of its segment names, runtime-target names, memo keys and gate facts, so that one
            demonstration can pick several objects (``PickAndCarry("obstacle", tag="obstacle/")`` has the
            segments ``obstacle/open`` …, the targets ``obstacle/grasp`` … and the gate fact
            ``obstacle/grasps``); empty for the object a family mainly picks. A tagged pick chooses its grasp
            when its pre-grasp is resolved, among the gate fact's grasps if the gate recorded one, else among
            those reachable from the live state; the episode's ``grasp_id`` stays the untagged pick's.
        support: the body the object rests on when it is picked (the lift may leave it touching that).
    """

    obj: str
    riders: tuple[str, ...] = ()
    grasp_filter: tuple[str, ...] = ()
    level: bool = False
    tag: str = ""
    support: str = "table"

    @property
    def _steps(self) -> PickPlace:
        return PickPlace(self.obj, self.tag, self.riders, self.support)

    def name(self, base: str) -> str:
        """The segment, runtime-target or memo name ``base`` of this pick (prefixed by ``tag``)."""
        return f"{self.tag}{base}"

    # -- segments --------------------------------------------------------------------------------------------
    def segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Open, pick, lift, carry into the goal and hold (the gate counts the hold)."""
        return [*self.pick_segments(ctx), *self.carry_segments(ctx)]

    def pick_segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Open, pre-grasp, approach, settle, close, lift to clearance."""
        if not self.tag:
            self.choose_grasp(ctx)
        return self._steps.pick(ctx.params)

    def carry_segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Carry the held object over the goal, lower it in and hold it still."""
        p = ctx.params
        held = {"gripper": "close", "attached": self.obj, "riders": self.riders,
                "speed": float(p["carry_speed"])}
        n = self.name
        carry = (s.linear(n("carry"), n("over_goal"), orientation="slerp", **held)  # type: ignore[arg-type]
                 if self.level else s.free(n("carry"), n("over_goal"), **held))  # type: ignore[arg-type]
        return [
            carry,
            s.linear(n("into_goal"), n("goal"), **held),  # type: ignore[arg-type]
            s.hold(n("hold"), steps=int(p["goal_hold_steps"]), gripper="close"),
        ]

    def place_segments(self, target: str, *, retreat_steps: int) -> list[s.MotionSegment]:
        """Lower the held object in a straight line to the runtime target ``target`` (a TCP pose; carry it
        above the spot first), release it and back off along the approach axis by the pre-grasp standoff."""
        return self._steps.place(target, retreat_steps=retreat_steps)

    # -- runtime targets -------------------------------------------------------------------------------------
    def resolve(self, name: str, ctx: Context) -> Pose | None:
        """The TCP pose of runtime target ``name`` (one of :data:`TARGETS`, after ``tag``), or None if it is
        not one."""
        if not name.startswith(self.tag):
            return None
        name = name[len(self.tag):]
        if self.tag and name == "pre_grasp":
            self.choose_grasp(ctx)
        if name in ("pre_grasp", "grasp"):
            grasp = self._grasp_pose(ctx)
            if name == "grasp":
                return grasp
            return backed_off(grasp, ctx.variation["grasp_standoff"])
        if name == "lift":
            return raised(ctx.commanded_tcp(), self._lift(ctx))
        if name in ("over_goal", "goal"):
            goal = ctx.memo.get(self.name("goal_tcp")) or self._goal_target(ctx)
            ctx.memo[self.name("goal_tcp")] = goal
            if name == "goal":
                return goal
            tcp = ctx.commanded_tcp()
            z = max(goal.pos[2] + float(ctx.param("goal_approach")), tcp.pos[2])
            return Pose(np.array([goal.pos[0], goal.pos[1], z]), goal.quat)
        if name == "retreat":
            return backed_off(ctx.commanded_tcp(), ctx.variation["grasp_standoff"])
        return None

    # -- grasps ----------------------------------------------------------------------------------------------
    def choose_grasp(self, ctx: Context) -> Grasp:
        """This attempt's grasp: round-robin (by draw) over the task's reachable valid grasps, or over the
        ``grasp_cycle`` most natural of them."""
        reachable = self._reachable(ctx)
        cycle = int(ctx.params.get(GRASP_CYCLE.name, GRASP_CYCLE.default))
        seeds: dict[str, np.ndarray] = {}
        if cycle and reachable:
            seeds = dict(self._most_natural_first(ctx, reachable)[:cycle])
            by_id = {g.id: g for g in reachable}
            reachable = tuple(by_id[i] for i in seeds) or reachable
        if not reachable:
            model, n = ctx.task.object(self.obj).model, len(ctx.grasps.get(self.obj, ()))
            why = (f"none of the {n} valid grasps of {model} is reachable from here" if n else
                   f"{model} has no valid grasps: run `mgdata grasps generate` then `mgdata grasps validate`")
            raise AttemptFailed("no_grasp", why)
        grasp = reachable[ctx.variation.pick(len(reachable))]
        ctx.memo[self.name("grasp")] = grasp
        if grasp.id in seeds:
            ctx.q_hints[self.name("pre_grasp")] = seeds[grasp.id]
        if not self.tag:
            ctx.memo["grasp_id"] = grasp.id
        return grasp

    def _most_natural_first(self, ctx: Context, grasps: tuple[Grasp, ...]) -> list[tuple[str, np.ndarray]]:
        """``(grasp id, arm configuration)`` of ``grasps``, the arm at the pre-grasp (``reach_standoff``
        back, IK from the home posture) nearest the home posture first, the DB's order breaking ties. The
        configuration seeds the pre-grasp's IK (``ctx.q_hints``), so every draw reaches it on one branch."""
        obj = ctx.object_pose(self.obj).matrix()
        rng = ctx.task_rng("grasp_rank")
        ranked: list[tuple[float, int, Grasp, np.ndarray]] = []
        for k, grasp in enumerate(grasps):
            pre = backed_off(Pose.from_matrix(obj @ grasp.matrix()), float(ctx.param("reach_standoff")))
            try:
                q = ctx.planner.ik(pre, HOME_Q, rng)
            except MotionFailure:
                continue
            ranked.append((float(np.linalg.norm(q - HOME_Q)), k, grasp, q))
        ranked.sort(key=lambda r: (r[0], r[1]))
        return [(r[2].id, r[3]) for r in ranked]

    def reachable_grasps(self, ctx: Context, allowed: AllowedContacts = NO_CONTACTS) -> tuple[Grasp, ...]:
        """Valid grasps whose pre-grasp (``reach_standoff`` back) and grasp poses (raised by the draw's
        ``grasp_height`` as :meth:`grasp_raise` caps it; the gate uses the midpoint) have IK solutions with
        ``grasp_margin`` from the joint limits and the arm ``grasp_clearance`` clear of everything but the
        object, its riders and the pairs in ``allowed`` (a wrist that grazes the table in the plan hits it
        once the servos sag). From the state in ``ctx`` with a task-derived seed, so every worker agrees."""
        pose_obj = ctx.object_pose(self.obj).matrix()
        margin = float(ctx.param("grasp_margin"))
        planner = ctx.planner
        touch = self._riders_touch(ctx) + AllowedContacts(((ROOT_BODY, self.obj),)) + allowed
        planner.checker.configure(touch, None, float(ctx.param("grasp_clearance")))
        standoff = float(ctx.param("reach_standoff"))
        rng = ctx.task_rng("grasp_reach")
        out = []
        for grasp in ctx.grasps.get(self.obj, ()):
            if self.grasp_filter and grasp.approach not in self.grasp_filter:
                continue
            raised = pose_obj.copy()
            raised[:3, 3] += raised[:3, 2] * self.grasp_raise(ctx, grasp)  # this draw's grasp height
            pose = Pose.from_matrix(raised @ grasp.matrix())
            pre = backed_off(pose, standoff)
            try:
                q_pre = planner.ik(pre, ctx.q_cmd, rng)
                q = planner.ik(pose, q_pre, rng)
            except MotionFailure:
                continue
            room = min(np.min(q - planner.lower), np.min(planner.upper - q),
                       np.min(q_pre - planner.lower), np.min(planner.upper - q_pre))
            if room >= margin and planner.checker.valid(q) and planner.checker.valid(q_pre):
                out.append(grasp)
        return tuple(out)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """The initial-state gate's check: ≥ ``min_grasps`` reachable grasps, and the goal reachable holding
        the object with the first of them. Returns ``{"grasps": ids}``."""
        reachable = self.reachable_grasps(ctx)
        if len(reachable) < max(min_grasps, 1):
            raise Infeasible("reach.grasps", f"{len(reachable)} of the {len(ctx.grasps.get(self.obj, ()))} "
                                             f"valid grasps of {self.obj} are reachable (needs {min_grasps})")
        ctx.memo[self.name("grasp")] = reachable[0]
        self.require_goal(ctx, self._grasp_pose(ctx), ctx.object_pose(self.obj))
        return {f"{self.tag}grasps": tuple(g.id for g in reachable)}

    def require_goal(self, ctx: Context, tcp: Pose, obj: Pose) -> None:
        """Raise ``reach.goal`` unless the arm reaches the goal holding the object as it is held with the TCP
        at ``tcp`` and the object at ``obj`` (a gate check; also for skeletons that pick otherwise)."""
        if self._goal_target(ctx, tcp=tcp, obj=obj, strict=True) is None:
            raise Infeasible("reach.goal", f"no turn of {self.obj} about the vertical "
                                           f"({list(ctx.param('carry_yaws_deg'))} deg) reaches the goal")

    def _reachable(self, ctx: Context) -> tuple[Grasp, ...]:
        """The gate's grasps (fact ``{tag}grasps``), else those reachable now (computed once)."""
        def now() -> tuple[Grasp, ...]:
            key = f"{self.tag}reachable/{self.obj}"
            if key not in ctx.memo:
                ctx.memo[key] = self.reachable_grasps(ctx)
            return ctx.memo[key]

        usable = usable_grasps(ctx, self.obj, f"{self.tag}grasps", now)
        return tuple(g for g in usable if not self.grasp_filter or g.approach in self.grasp_filter)

    def _grasp_pose(self, ctx: Context) -> Pose:
        grasp: Grasp = ctx.memo[self.name("grasp")]
        local = grasp.matrix()
        local[2, 3] += self.grasp_raise(ctx, grasp)
        return Pose.from_matrix(ctx.object_pose(self.obj).matrix() @ local)

    def grasp_raise(self, ctx: Context, grasp: Grasp) -> float:
        """How far (m) ``grasp`` is raised along the object's vertical axis: the draw's ``grasp_height``,
        capped so the TCP stays ``rim_clearance`` below the object's top when the recipe sets one."""
        raise_by = float(ctx.variation["grasp_height"])
        clearance = float(ctx.params.get(RIM_CLEARANCE.name, RIM_CLEARANCE.default))
        if clearance > 0.0:
            top = ctx.scene.objects[self.obj].size[2]
            raise_by = min(raise_by, top - clearance - float(grasp.pos[2]))
        return raise_by

    # -- lifting and the goal --------------------------------------------------------------------------------
    def _lift(self, ctx: Context) -> float:
        """How far up (m) the TCP goes: the held object's lowest point ``lift_margin`` above the tallest
        other rigid object, and at least ``lift_height``."""
        scene = ctx.scene
        skip = {self.obj, *self.riders}
        tops = [scene.object_pose(n)[0][2] + m.size[2] for n, m in scene.objects.items()
                if n not in skip and m.particles is None and not m.fixed]
        low = LowestPoint(scene.model, scene.object_geom_ids(self.obj))(scene.data)
        need = (max(tops) + float(ctx.param("lift_margin")) - low) if tops else 0.0
        return max(float(ctx.variation["lift_height"]), need)

    def _goal_target(self, ctx: Context, *, tcp: Pose | None = None, obj: Pose | None = None,
                     strict: bool = False) -> Pose | None:
        """TCP pose that puts the held object's bounding-box centre at the goal centre (offset by the draw),
        turned about the vertical by the first of ``carry_yaws_deg`` the arm can reach holding it (the
        object stays upright). ``strict``: None if no turn is reachable (else the first turn)."""
        goal = ctx.task.goal
        if goal is None:
            raise AttemptFailed("target_fail", f"the task has no goal region for {self.obj}")
        start: Pose = obj or ctx.object_pose(self.obj)
        riders = tuple(b for r in self.riders for b in ctx.scene.loose_bodies(r))
        held = held_object(ctx, self.obj, tcp=tcp, pose=start, riders=riders)
        centre_local = np.asarray(ctx.scene.object_model(self.obj).size) * np.array([0.0, 0.0, 0.5])
        centre = np.asarray(goal.pos) + np.array([ctx.variation["goal_dx"], ctx.variation["goal_dy"], 0.0])
        rng = ctx.variation.rng("carry_yaw")
        allowed = self._riders_touch(ctx)

        def at_goal(yaw: float) -> Pose:
            rot = (Pose(np.zeros(3), about_z(math.radians(yaw))) @ Pose(np.zeros(3), start.quat)).quat
            return held.tcp_for(Pose(centre - Pose(np.zeros(3), rot).rotation() @ centre_local, rot))

        search = first_reachable(map(at_goal, ctx.param("carry_yaws_deg")), lambda target: ctx.planner.ik(
            target, ctx.q_cmd, rng, collision_free=True, allowed=allowed, attached=held.attachment))
        return search.found if strict else search.found_or_first

    # -- contacts --------------------------------------------------------------------------------------------
    def _riders_touch(self, ctx: Context) -> AllowedContacts:
        """The robot may touch the riders (they move with the object, never block the arm)."""
        return AllowedContacts(tuple((ROOT_BODY, b) for r in self.riders for b in ctx.scene.loose_bodies(r)))
