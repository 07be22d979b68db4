"""Cabinet: move what stands in the drawer's way, open the drawer, put the target inside, close the drawer.

The paper's "four-phase articulated sequence (relocate → open → place → close)":

1. **Relocate.** An object (obstacle first, then target) whose footprint comes within ``sweep_margin`` of the
   volume the drawer and its handle sweep when opened to this attempt's stroke is in the way (the bottle
   would be knocked over, the target would end up under the open drawer). It is picked, carried in a
   straight line and put down upright on a free spot of ``clear_region`` outside the sweep, away from
   everything else and ``clear_arm_margin`` from the arm's later drawer and pick motions, and released.
2. **Open.** A drawer-handle grasp from the grasp DB: pre-grasp, approach, close on the bar, pull along the
   slide axis to ``stroke`` × the travel (slowed to ``pull_speed``), release, back off.
3. **Place.** Pick the target, carry it over the exposed part of the drawer with its bottom ``rim_clear``
   above the rim (turned about the vertical by the first of ``drawer_yaws_deg`` whose footprint fits the
   opening and that the arm reaches), lower it to ``put_drop`` above the drawer's floor, release, rise.
4. **Close.** Grasp the handle again, push the drawer shut (``close_overshoot`` past closed), release, back
   off and hold still: the gate needs the target inside the closed drawer, at rest.

Phases (restarts, :mod:`mgdata.skeleton.phase`): ``open`` (1-2) and ``place``, done once ``target_inside``
holds, and ``close``, done once ``drawer_closed`` holds. Numbers come from ``recipes/cabinet.toml``.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.grasps.db import Grasp
from mgdata.motion import AllowedContacts, Pose
from mgdata.sim.robot import ROOT_BODY
from mgdata.skeleton import segment as s
from mgdata.skeleton.articulation import Drawer, HandleDrive
from mgdata.skeleton.context import Context
from mgdata.skeleton.grasp_choice import choose_grasp
from mgdata.skeleton.opening import into_opening
from mgdata.skeleton.phase import Phase
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.poses import backed_off, raised
from mgdata.skeleton.reach import arm_path, reaches_grasp
from mgdata.skeleton.relocate import Relocate
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Knob, Param, RecipeKeys, register
from mgdata.skeleton.spots import SpotRules, free_spot
from mgdata.skeleton.whatif import keeps_clear, live_what_if, planner_what_if

CABINET, TARGET, OBSTACLE = "cabinet", "target", "obstacle"
DRAWER = Drawer(CABINET)
TOUCH_CABINET = (("hand", CABINET),)
HANDLE = HandleDrive(DRAWER, TOUCH_CABINET, moving=((ROOT_BODY, f"{CABINET}/drawer"),))
"""The planner's drawer stays behind while the hand moves the real one: the arm may overlap that copy."""
BLOCKERS = (OBSTACLE, TARGET)
"""Relocated in this order when in the drawer's way."""
RELOCATE = {OBSTACLE: Relocate(OBSTACLE, grasp_filter=("side",)), TARGET: Relocate(TARGET)}
"""How each blocker is moved. The bottle by its body: put down from a pinch at its neck, it can catch under
its cap on the opening finger and come up with the hand."""


@register
class CabinetSkeleton(FamilySkeleton):
    """The cabinet family's demonstration (see the module docstring)."""

    name = "cabinet"
    recipe_keys = PICK_AND_CARRY_KEYS + RecipeKeys(
        params=(
            Param("sweep_margin", float, "m around the drawer's swept volume that counts as in the way",
                  0.0, 0.2),
            Param("clear_region", tuple, "x0, x1, y0, y1 (m) where blockers are put down", -1.5, 1.5),
            Param("clear_spacing", float, "m between candidate spots for a blocker", 0.005, 0.2),
            Param("clear_clearance", float, "m between a put-down blocker and every other object", 0.0, 0.2),
            Param("clear_arm_margin", float,
                  "m a put-down blocker keeps from the arm's later drawer and pick motions", 0.0, 0.2),
            Param("put_drop", float, "m above its support an object is released", 0.0, 0.05),
            Param("rim_clear", float, "m the carried target's bottom clears the drawer's rim", 0.0, 0.2),
            Param("drawer_yaws_deg", tuple, "turns of the target about the vertical tried over the drawer",
                  -180.0, 180.0),
            Param("handle_settle_steps", int, "control steps at the handle before closing on it", 0, 200),
            Param("pull_speed", float, "fraction of the planned speed while moving the drawer", 0.01, 1.0),
            Param("close_overshoot", float, "m the handle is pushed past the closed position", 0.0, 0.02),
            Param("handle_retreat", float, "m the hand backs off the handle after releasing it", 0.0, 0.2),
            Param("fit_clearance", float, "m the target stays below the drawer's top rim", 0.0, 0.1),
        ),
        variation=(
            Knob("stroke", "drawer opening as a fraction of its travel", 0.3, 1.0),
            Knob("handle_standoff", "m back from the handle for the pre-grasp", 0.0, 0.3),
            Knob("drawer_dx", "m offset of the drop point along the drawer's width", -0.1, 0.1),
            Knob("clear_pick", "which free spot a blocker goes to (fraction through the candidates)",
                 0.0, 1.0),
        ),
    )
    target = PickAndCarry(TARGET, grasp_filter=("top_down",))
    """Only grasps from above: the hand stays over the drawer's rim (a side grasp's would hit its walls)."""

    # -- phases: (relocate ->) open -> place -> close ----------------------------------------------------
    def phases(self, ctx: Context) -> Sequence[Phase]:
        relocate = [seg for role in self.in_the_way(ctx) for seg in RELOCATE[role].segments(ctx)]
        return [Phase("open", (*relocate, *self._open(ctx)), done="target_inside"),
                Phase("place", tuple(self._place(ctx)), done="target_inside"),
                Phase("close", tuple(self._close(ctx)), done="drawer_closed")]

    def _open(self, ctx: Context) -> list[s.MotionSegment]:
        ctx.memo["handle"] = choose_grasp(ctx, CABINET, "handle_grasps", lambda: self.handle_grasps(ctx),
                                          none="no valid handle grasp of the cabinet is reachable")
        return self._handle(ctx, "drawer_open/", "pulled")

    def _place(self, ctx: Context) -> list[s.MotionSegment]:
        p = ctx.params
        return [*self.target.pick_segments(ctx),
                s.linear("raise", "raised", gripper="close", attached=TARGET),
                s.linear("to_drawer", "over_drawer", orientation="slerp", speed=p["carry_speed"],
                         gripper="close", attached=TARGET),
                s.linear("into_drawer", "in_drawer", allow=((TARGET, CABINET),), gripper="close",
                         attached=TARGET),
                s.gripper("drop", "open", steps=p["open_steps"]),
                s.linear("rise", "rise", allow=(("hand", TARGET),))]

    def _close(self, ctx: Context) -> list[s.MotionSegment]:
        return [*self._handle(ctx, "drawer_close/", "pushed", riders=(TARGET,)),
                s.hold("rest", steps=ctx.params["goal_hold_steps"])]

    @staticmethod
    def _handle(ctx: Context, tag: str, end: str, riders: tuple[str, ...] = ()) -> list[s.MotionSegment]:
        """Grasp the handle, move it to runtime target ``end`` holding it, release, back off."""
        p = ctx.params
        return HANDLE.segments(tag, end, open_steps=p["open_steps"], settle_steps=p["handle_settle_steps"],
                               close_steps=p["close_steps"], speed=p["pull_speed"], riders=riders)

    # -- runtime targets -------------------------------------------------------------------------------------
    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.startswith("handle") or name in ("pulled", "pushed"):
            return self._handle_target(name, ctx)
        if name in ("over_drawer", "in_drawer"):
            return self._drawer_target(ctx)[0 if name == "over_drawer" else 1]
        if name == "raised":  # straight up to the height of the carry over the drawer
            tcp, over = ctx.commanded_tcp(), self._drawer_target(ctx)[0]
            return Pose(np.array([tcp.pos[0], tcp.pos[1], max(tcp.pos[2], over.pos[2])]), tcp.quat)
        if name == "rise":
            up = ctx.scene.object_model(TARGET).size[2] + ctx.param("rim_clear")
            return raised(ctx.commanded_tcp(), up)
        for role in BLOCKERS:
            pose = RELOCATE[role].resolve(name, ctx, lambda role=role: self._spot_target(ctx, role))
            if pose is not None:
                return pose
        return self.target.resolve(name, ctx) or super().resolve(name, ctx)

    def _handle_target(self, name: str, ctx: Context) -> Pose:
        ends = {"pulled": self.stroke(ctx), "pushed": -ctx.param("close_overshoot")}
        return HANDLE.target(ctx, name, ctx.memo["handle"], standoff=ctx.variation["handle_standoff"],
                             retreat=ctx.param("handle_retreat"), ends=ends) or super().resolve(name, ctx)

    # -- the drawer's sweep ----------------------------------------------------------------------------------
    @staticmethod
    def stroke(ctx: Context) -> float:  # this attempt's opening (m along the slide)
        return ctx.variation["stroke"] * DRAWER.travel(ctx)

    def in_the_way(self, ctx: Context) -> list[str]:
        """The blockers (obstacle first) whose footprint comes within ``sweep_margin`` of the sweep."""
        return DRAWER.in_the_way(ctx, BLOCKERS, stroke=self.stroke(ctx), margin=ctx.param("sweep_margin"))

    # -- putting things down ---------------------------------------------------------------------------
    def _spot_target(self, ctx: Context, role: str) -> tuple[Pose, Pose]:
        """TCP poses above and at a free spot for ``role`` (computed once): outside the sweep,
        ``clear_arm_margin`` from the arm's later motions and, for the target, where its grasp reaches it."""
        key, p, v = f"{role}/spot_tcp", ctx.params, ctx.variation
        if key not in ctx.memo:
            rules = SpotRules(p["clear_region"], p["clear_spacing"], p["clear_clearance"], (CABINET,),
                              lambda xy: DRAWER.sweep_gap(ctx, xy, self.stroke(ctx)), p["sweep_margin"],
                              v["clear_pick"], p["put_drop"], v["grasp_standoff"],
                              "in clear_region outside the sweep")
            later = functools.cache(lambda: np.vstack(self._later_arm_path(ctx, role) or [np.zeros((0, 7))]))

            def leaves_clear(at: Pose) -> bool:
                path = later()  # planned in the live scene (it syncs the planner): before the what-if
                with planner_what_if(ctx, objects={role: at}, articulations={CABINET: self.stroke(ctx)}):
                    if not keeps_clear(ctx, role, path, p["clear_arm_margin"]):
                        return False
                    return role != TARGET or reaches_grasp(
                        ctx, at @ Pose.from_matrix(ctx.memo["grasp"].matrix()), v["grasp_standoff"],
                        ctx.task_rng("target_at_spot"), allowed=AllowedContacts(((ROOT_BODY, TARGET),)))

            ctx.memo[key] = free_spot(ctx, role, rules, rng=v.rng(f"spot/{role}"), accept=leaves_clear)
        return ctx.memo[key]

    def _later_arm_path(self, ctx: Context, role: str) -> list[np.ndarray]:
        """The arm's path after ``role`` is put down, as the executor will plan it (objects left out): handle
        approach, pull, back-off (the push retraces the pull), and the target's pre-grasp and grasp."""
        rng = ctx.task_rng("arm_path_later")
        loose = AllowedContacts(tuple((ROOT_BODY, o.name) for o in ctx.task.objects))
        path = HANDLE.arm_path(ctx, ctx.memo["handle"], by=self.stroke(ctx),
                               standoff=ctx.variation["handle_standoff"], rng=rng, allowed=loose)
        if len(path) == 4 and role != TARGET and "grasp" in ctx.memo:
            grasp_tcp = Pose.from_matrix(ctx.object_pose(TARGET).matrix() @ ctx.memo["grasp"].matrix())
            path += arm_path(ctx, [backed_off(grasp_tcp, ctx.variation["grasp_standoff"]), grasp_tcp], rng,
                             q0=path[-1][-1], allowed=loose, with_start=False)
        return path

    def _drawer_target(self, ctx: Context) -> tuple[Pose, Pose]:
        """TCP poses over the drawer's opening and down in it, for the held target (computed once)."""
        if "drawer_tcp" not in ctx.memo:
            opening, yaws = DRAWER.opening(ctx), ctx.param("drawer_yaws_deg")
            search = into_opening(ctx, TARGET, opening, yaws=yaws, dy=ctx.variation["drawer_dx"],
                                  drop=ctx.param("put_drop"), clear=ctx.param("rim_clear"),
                                  rng=ctx.variation.rng("drawer"), touch=CABINET)
            if search.found is None:
                why = search.failure.reason if search.failure else opening.describe()
                raise AttemptFailed("target_fail", f"no turn of the target ({list(yaws)} deg) fits the "
                                                   f"drawer's opening and is reachable ({why})")
            ctx.memo["drawer_tcp"] = search.found
        return ctx.memo["drawer_tcp"]

    # -- the initial-state gate ------------------------------------------------------------------------------
    def moved_first(self, ctx: Context) -> AllowedContacts:
        """The blockers :meth:`in_the_way` as robot contacts allowed after their relocation (clear of it)."""
        return AllowedContacts(tuple((ROOT_BODY, r) for r in self.in_the_way(ctx)))

    def handle_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        """The handle grasps that drive the drawer to the stroke, only the blockers moved first in the way."""
        moved, v = self.moved_first(ctx), ctx.variation
        return DRAWER.drivable_grasps(ctx, ctx.grasps.get(CABINET, ()), stroke=self.stroke(ctx),
                                      standoff=v["handle_standoff"], margin=ctx.param("grasp_margin"),
                                      rng=ctx.task_rng("handle_reach"), allowed=moved,
                                      touch=AllowedContacts(TOUCH_CABINET) + moved)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """The target fits under the drawer's rim; a handle grasp is reachable closed and pulled open; the
        target (with the drawer open, the obstacle moved) and each blocker have enough reachable grasps."""
        room = ctx.scene.object_model(CABINET).geometry["drawer_inner"][2] - ctx.param("fit_clearance")
        tall = ctx.scene.object_model(TARGET).size[2]
        if tall > room:
            raise Infeasible("fit.height", f"the target is {tall * 100:.1f} cm tall; the drawer takes "
                                           f"{room * 100:.1f} cm")
        handles = self.handle_grasps(ctx)
        if not handles:
            raise Infeasible("reach.handle", "no valid handle grasp is reachable at both ends of the stroke")
        facts: dict[str, object] = {"handle_grasps": tuple(g.id for g in handles)}
        moved = AllowedContacts(tuple(p for p in self.moved_first(ctx).pairs if p[1] != TARGET))
        with live_what_if(ctx, {CABINET: self.stroke(ctx)}):
            targets = self.target.reachable_grasps(ctx, moved)
        if len(targets) < max(min_grasps, 1):
            raise Infeasible("reach.grasps", f"{len(targets)} of the {len(ctx.grasps.get(TARGET, ()))} valid "
                                             f"grasps of the target are reachable (needs {min_grasps})")
        facts["grasps"] = tuple(g.id for g in targets)
        for role in self.in_the_way(ctx):
            found = RELOCATE[role].pick.reachable_grasps(ctx)
            if not found:
                raise Infeasible("reach.blocker", f"the {role} is in the drawer's way and none of its grasps "
                                                  "is reachable")
            facts[f"{role}/grasps"] = tuple(g.id for g in found)
        return {**facts, "in_the_way": tuple(self.in_the_way(ctx))}
