"""Cabinet: move what stands in the drawer's way, open the drawer, put the target inside, close the drawer.

The paper's "four-phase articulated sequence (relocate → open → place → close)":

1. **Relocate.** An object (obstacle first, then target) whose footprint comes within ``sweep_margin`` of the
   volume the drawer and its handle sweep when opened to this attempt's stroke is in the way: the obstacle
   (a bottle, taller than the drawer's underside) would be knocked over, and the target would end up under
   the open drawer, out of the gripper's reach. It is picked (Layer 2's pick-and-carry), carried in a
   straight line and put down upright on a free spot of ``clear_region`` outside the sweep, away from
   everything else and ``clear_arm_margin`` from the arm's later drawer and pick motions, and released.
2. **Open.** A drawer-handle grasp from the grasp DB (in the drawer's frame, ``Grasp.world_matrix``):
   pre-grasp, approach, close on the bar, pull along the slide axis to ``stroke`` × the travel (slowed to
   ``pull_speed``), release, back off.
3. **Place.** Pick the target, carry it over the exposed part of the drawer with its bottom ``rim_clear``
   above the rim (turned about the vertical by the first of ``drawer_yaws_deg`` whose footprint fits the
   opening and that the arm reaches), lower it to ``put_drop`` above the drawer's floor, release, rise.
4. **Close.** Grasp the handle again, push the drawer shut (``close_overshoot`` past closed, the joint stop
   holds the drawer), release, back off and hold still: the gate needs the target inside the closed drawer,
   at rest.

The drawer keeps the asset's joint parameters (damping, friction) for the whole episode. Numbers come from
``recipes/cabinet.toml``.
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Sequence

import mujoco
import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.grasps.db import Grasp
from mgdata.motion import AllowedContacts, Attachment, MotionFailure, Pose
from mgdata.sim.robot import ROOT_BODY
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Knob, Param, RecipeKeys, register
from mgdata.tasks.placer import footprint_radius

CABINET, TARGET, OBSTACLE = "cabinet", "target", "obstacle"
TOUCH_CABINET = (("hand", CABINET),)
ARM_ON_DRAWER = ((ROOT_BODY, f"{CABINET}/drawer"),)
"""While the hand moves the drawer, the planner's drawer stays where it was when the line was planned; the
real one moves along with the hand, so the arm may overlap the planner's copy (pushing it shut). The carcass
is still checked; contacts with the real drawer are the physics' business."""
BLOCKERS = (OBSTACLE, TARGET)
"""Relocated in this order when in the drawer's way."""


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
    """Only grasps from above: the hand stays over the drawer's rim while the target goes in (a side grasp's
    hand would hit the drawer's walls)."""

    # -- segments --------------------------------------------------------------------------------------------
    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        segs: list[s.MotionSegment] = []
        for role in self.in_the_way(ctx):
            segs += self._relocate(ctx, role)
        return [*segs, *self._open(ctx), *self._place(ctx), *self._close(ctx)]

    def _relocate(self, ctx: Context, role: str) -> list[s.MotionSegment]:
        """Pick ``role``, put it down on a free spot outside the sweep, release it, back off."""
        carry = self._mover(role)
        t, p = carry.tag, ctx.params
        return [
            *carry.pick_segments(ctx),
            s.linear(f"{t}carry", f"{t}over_spot", orientation="slerp", gripper="close", attached=role,
                     speed=float(p["carry_speed"])),
            *carry.place_segments(f"{t}spot", retreat_steps=int(p["open_steps"])),
        ]

    def _handle(self, ctx: Context, tag: str, end: str,
                riders: tuple[str, ...] = ()) -> list[s.MotionSegment]:
        """Grasp the handle, move it to runtime target ``end`` holding it (``riders``: objects in the drawer,
        moving with it), release, back off."""
        p = ctx.params
        return [
            s.gripper(f"{tag}open", "open", steps=int(p["open_steps"])),
            s.free(f"{tag}pre", "handle_pre"),
            s.linear(f"{tag}approach", "handle", allow=TOUCH_CABINET),
            s.hold(f"{tag}settle", steps=int(p["handle_settle_steps"])),
            s.gripper(f"{tag}grip", "close", steps=int(p["close_steps"])),
            s.linear(f"{tag}move", end, gripper="close", allow=TOUCH_CABINET + ARM_ON_DRAWER,
                     riders=riders, speed=float(p["pull_speed"])),
            s.gripper(f"{tag}release", "open", steps=int(p["open_steps"])),
            s.linear(f"{tag}back", "handle_back", allow=TOUCH_CABINET),
        ]

    def _open(self, ctx: Context) -> list[s.MotionSegment]:
        self._choose_handle(ctx)
        return self._handle(ctx, "drawer_open/", "pulled")

    def _place(self, ctx: Context) -> list[s.MotionSegment]:
        p = ctx.params
        held = {"gripper": "close", "attached": TARGET}
        return [
            *self.target.pick_segments(ctx),
            s.linear("raise", "raised", **held),  # type: ignore[arg-type]
            s.linear("to_drawer", "over_drawer", orientation="slerp", speed=float(p["carry_speed"]),
                     **held),  # type: ignore[arg-type]
            s.linear("into_drawer", "in_drawer", allow=((TARGET, CABINET),), **held),  # type: ignore[arg-type]
            s.gripper("drop", "open", steps=int(p["open_steps"])),
            s.linear("rise", "rise", allow=(("hand", TARGET),)),
        ]

    def _close(self, ctx: Context) -> list[s.MotionSegment]:
        return [*self._handle(ctx, "drawer_close/", "pushed", riders=(TARGET,)),
                s.hold("rest", steps=int(ctx.params["goal_hold_steps"]))]

    @staticmethod
    def _mover(role: str) -> PickAndCarry:
        return PickAndCarry(role, tag=f"{role}/")

    # -- the drawer's geometry -------------------------------------------------------------------------------
    @staticmethod
    def _cabinet(ctx: Context) -> tuple[Pose, dict]:
        return ctx.object_pose(CABINET), dict(ctx.scene.object_model(CABINET).geometry)

    @staticmethod
    def stroke(ctx: Context) -> float:
        """This attempt's opening (m along the slide)."""
        return float(ctx.variation["stroke"]) * float(ctx.scene.object_model(CABINET).geometry["travel"])

    @staticmethod
    def drawer_q(ctx: Context) -> float:
        """The drawer's slide position now (m)."""
        return float(ctx.scene.data.qpos[ctx.scene.articulation_qpos_adr(CABINET)])

    def sweep(self, ctx: Context) -> tuple[np.ndarray, np.ndarray]:
        """The xy box (cabinet frame, lo and hi) the drawer and its handle sweep when opened to the stroke."""
        _, geo = self._cabinet(ctx)
        hy = float(geo["half_extents"][1])
        reach = float(geo["handle_pos"][0]) + float(geo["handle_radius"]) + self.stroke(ctx)
        return np.array([float(geo["front_x"]), -hy]), np.array([reach, hy])

    def in_the_way(self, ctx: Context) -> list[str]:
        """The blockers (obstacle first) whose footprint comes within ``sweep_margin`` of the sweep."""
        return [r for r in BLOCKERS if self._near_sweep(ctx, ctx.object_pose(r).pos[:2],
                                                        footprint_radius(ctx.task.object(r).model),
                                                        float(ctx.param("sweep_margin")))]

    def _near_sweep(self, ctx: Context, xy: np.ndarray, radius: float, margin: float) -> bool:
        return self._sweep_gap(ctx, xy) < radius + margin

    def _sweep_gap(self, ctx: Context, xy: np.ndarray) -> float:
        """Distance (m) from the world point ``xy`` to the sweep's box (0 inside it)."""
        cab, _ = self._cabinet(ctx)
        rot = cab.rotation()[:2, :2]
        local = rot.T @ (np.asarray(xy) - cab.pos[:2])
        lo, hi = self.sweep(ctx)
        gap = np.maximum(np.maximum(lo - local, local - hi), 0.0)
        return float(np.hypot(*gap))

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
            tcp = ctx.commanded_tcp()
            up = float(ctx.scene.object_model(TARGET).size[2]) + float(ctx.param("rim_clear"))
            return Pose(tcp.pos + np.array([0.0, 0.0, up]), tcp.quat)
        for role in BLOCKERS:
            tag = f"{role}/"
            if name in (f"{tag}over_spot", f"{tag}spot"):
                return self._spot_target(ctx, role)[0 if name.endswith("over_spot") else 1]
        for carry in (self.target, self._mover(OBSTACLE), self._mover(TARGET)):
            pose = carry.resolve(name, ctx)
            if pose is not None:
                return pose
        return super().resolve(name, ctx)

    # -- the handle ------------------------------------------------------------------------------------------
    def moved_first(self, ctx: Context) -> AllowedContacts:
        """The blockers :meth:`in_the_way` as robot contacts to allow in checks of what comes after their
        relocation (the handle's motions, the target's pick from the open drawer's side): by then they stand
        on spots kept ``clear_arm_margin`` from those motions. The cabinet, the table and every object left
        where it is still count."""
        return AllowedContacts(tuple((ROOT_BODY, r) for r in self.in_the_way(ctx)))

    def handle_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        """The cabinet's valid handle grasps with a collision-free pre-grasp ``grasp_margin`` from the joint
        limits, whose straight approach and pull lines (planned as the executor will: the hand may touch the
        cabinet, nothing else may but the blockers relocated first) solve, every configuration
        ``grasp_margin`` from the joint limits."""
        stroke = self.stroke(ctx)
        planner, data, model = ctx.planner, ctx.scene.data, ctx.scene.model
        margin = float(ctx.param("grasp_margin"))
        axis = ctx.object_pose(CABINET).rotation()[:, 0]
        rng = np.random.default_rng(np.random.SeedSequence([ctx.task.seed, 0xCAB]))
        moved = self.moved_first(ctx)
        touch = AllowedContacts(TOUCH_CABINET) + moved
        planner.sync(data)
        out = []
        for grasp in ctx.grasps.get(CABINET, ()):
            pose = Pose.from_matrix(grasp.world_matrix(model, data, CABINET))
            pre = Pose(pose.pos - pose.rotation()[:, 2] * float(ctx.variation["handle_standoff"]), pose.quat)
            pulled = Pose(pose.pos + axis * stroke, pose.quat)
            try:  # a pre-grasp solution near a joint limit is no reason to drop the grasp: take another
                q_pre = planner.ik(pre, ctx.q_cmd, rng, collision_free=True, allowed=moved,
                                   limit_margin=margin)
                approach = planner.line(q_pre, pose, rng, allowed=touch)
                pull = planner.line(approach.q[-1], pulled, rng, allowed=touch)
            except MotionFailure:
                continue
            qs = np.vstack([q_pre[None], approach.q, pull.q])
            room = float(np.min(np.minimum(qs - planner.lower, planner.upper - qs)))
            if room >= margin:
                out.append(grasp)
        return tuple(out)

    def _choose_handle(self, ctx: Context) -> Grasp:
        ids = ctx.task.gate.get("handle_grasps")
        grasps = ctx.grasps.get(CABINET, ())
        usable = tuple(g for g in grasps if g.id in ids) if ids is not None else self.handle_grasps(ctx)
        if not usable:
            raise AttemptFailed("no_grasp", "no valid handle grasp of the cabinet is reachable")
        grasp = usable[ctx.variation.pick(len(usable))]
        ctx.memo["handle"] = grasp
        return grasp

    def _handle_target(self, name: str, ctx: Context) -> Pose:
        grasp: Grasp = ctx.memo["handle"]
        pose = Pose.from_matrix(grasp.world_matrix(ctx.scene.model, ctx.scene.data, CABINET))
        approach = pose.rotation()[:, 2]
        axis = ctx.object_pose(CABINET).rotation()[:, 0]
        q = self.drawer_q(ctx)
        if name == "handle":
            return pose
        if name == "handle_pre":
            return Pose(pose.pos - approach * float(ctx.variation["handle_standoff"]), pose.quat)
        if name == "handle_back":
            tcp = ctx.commanded_tcp()
            return Pose(tcp.pos - tcp.rotation()[:, 2] * float(ctx.param("handle_retreat")), tcp.quat)
        if name == "pulled":
            return Pose(pose.pos + axis * (self.stroke(ctx) - q), pose.quat)
        if name == "pushed":
            return Pose(pose.pos - axis * (q + float(ctx.param("close_overshoot"))), pose.quat)
        return super().resolve(name, ctx)

    # -- putting things down ---------------------------------------------------------------------------------
    def _held(self, ctx: Context, obj: str) -> tuple[Pose, Attachment]:
        """The held object's pose in the TCP frame (both measured now) and its attachment for the planner."""
        tcp_t_obj = ctx.tcp_pose().inverse() @ ctx.object_pose(obj)
        return tcp_t_obj, Attachment(obj, tcp_t_obj.matrix())

    def _spot_target(self, ctx: Context, role: str) -> tuple[Pose, Pose]:
        """TCP poses above and at a free spot for ``role`` (computed once): the first reachable candidate,
        starting ``clear_pick`` of the way through the grid over ``clear_region``."""
        key = f"{role}/spot_tcp"
        if key in ctx.memo:
            return ctx.memo[key]
        x0, x1, y0, y1 = (float(v) for v in ctx.param("clear_region"))
        step, gap = float(ctx.param("clear_spacing")), float(ctx.param("clear_clearance"))
        radius = footprint_radius(ctx.task.object(role).model)
        others = [(ctx.object_pose(o.name).pos[:2], footprint_radius(o.model)) for o in ctx.task.objects
                  if o.name not in (role, CABINET)]
        spots = [np.array([x, y]) for x in np.arange(x0, x1 + 1e-9, step)
                 for y in np.arange(y0, y1 + 1e-9, step)]
        spots = [p for p in spots if all(np.linalg.norm(p - c) >= radius + r + gap for c, r in others)
                 and not self._near_sweep(ctx, p, radius, float(ctx.param("sweep_margin")))]
        if not spots:
            raise AttemptFailed("target_fail", f"no free spot for {role} in clear_region outside the sweep")
        # farthest from the drawer first (the arm pulls the drawer open next to it), the draw picks among
        # the farthest third
        spots.sort(key=lambda p: -self._sweep_gap(ctx, p))
        start = int(ctx.variation["clear_pick"] * max(1, len(spots) // 3)) % len(spots)
        tcp_t_obj, held = self._held(ctx, role)
        obj = ctx.object_pose(role)
        upright = Pose(np.zeros(3), self._yaw_only(obj.quat))
        rng = ctx.variation.rng(f"spot/{role}")
        lift = ctx.commanded_tcp().pos[2]
        later = self._later_arm_path(ctx, role)
        for i in range(len(spots)):
            xy = spots[(start + i) % len(spots)]
            at = Pose(np.array([xy[0], xy[1], TABLE_TOP_Z + float(ctx.param("put_drop"))]), upright.quat)
            if not self._spot_leaves_clear(ctx, role, at, later):
                continue
            down = at @ tcp_t_obj.inverse()
            above = Pose(np.array([down.pos[0], down.pos[1], max(lift, down.pos[2] + 0.04)]), down.quat)
            back = Pose(down.pos - down.rotation()[:, 2] * float(ctx.variation["grasp_standoff"]), down.quat)
            try:  # the carry, put-down and retreat lines, as the executor plans them
                carry = ctx.planner.line(ctx.q_cmd, above, rng, orientation="slerp", attached=held)
                put = ctx.planner.line(carry.q[-1], down, rng, allowed=AllowedContacts(((role, "table"),)),
                                       attached=held)
                # (the planner's copy of the object is still in the hand, not on the spot: leave it out)
                ctx.planner.line(put.q[-1], back, rng, allowed=AllowedContacts(((ROOT_BODY, role),)))
            except MotionFailure:
                continue
            ctx.memo[key] = (above, down)
            return above, down
        raise AttemptFailed("target_fail", f"no free spot for {role} is reachable holding it")

    def _later_arm_path(self, ctx: Context, role: str) -> np.ndarray:
        """Arm configurations (N, 7) of what comes after ``role`` is put down, planned now as the executor
        will plan them: the chosen handle grasp's approach, the pull to the stroke, the back-off (which is
        also where the close starts; the push retraces the pull) and, unless the target is the one put down,
        the target's pre-grasp and grasp. Objects are left out of the lines (only their relation to the spot
        matters here); a part that does not solve now is left out (the executor then fails on it anyway)."""
        planner, model, data = ctx.planner, ctx.scene.model, ctx.scene.data
        rng = np.random.default_rng(np.random.SeedSequence([ctx.task.seed, 0x5B07]))
        loose = AllowedContacts(tuple((ROOT_BODY, o.name) for o in ctx.task.objects))
        planner.sync(data)
        grasp: Grasp = ctx.memo["handle"]
        pose = Pose.from_matrix(grasp.world_matrix(model, data, CABINET))
        back = pose.rotation()[:, 2] * float(ctx.variation["handle_standoff"])
        pulled = Pose(pose.pos + ctx.object_pose(CABINET).rotation()[:, 0] * self.stroke(ctx), pose.quat)
        path: list[np.ndarray] = []
        with contextlib.suppress(MotionFailure):  # the rest is left out: the executor fails on it
            q = planner.ik(Pose(pose.pos - back, pose.quat), ctx.q_cmd, rng)
            path.append(q[None])
            for goal in (pose, pulled, Pose(pulled.pos - back, pulled.quat)):
                line = planner.line(path[-1][-1], goal, rng, allowed=loose)
                path.append(line.q)
            if role != TARGET and "grasp" in ctx.memo:
                grasp_tcp = Pose.from_matrix(ctx.object_pose(TARGET).matrix() @ ctx.memo["grasp"].matrix())
                standoff = float(ctx.variation["grasp_standoff"])
                pre = Pose(grasp_tcp.pos - grasp_tcp.rotation()[:, 2] * standoff, grasp_tcp.quat)
                q = planner.ik(pre, path[-1][-1], rng)
                path.append(planner.line(q, grasp_tcp, rng, allowed=loose).q)
        return np.vstack(path) if path else np.zeros((0, 7))

    def _spot_leaves_clear(self, ctx: Context, role: str, at: Pose, later: np.ndarray) -> bool:
        """Whether ``role`` standing at ``at`` stays ``clear_arm_margin`` from the arm on the ``later`` path
        and, if it is the target, one of its grasps is still reachable there with the drawer open."""
        scene, planner = ctx.scene, ctx.planner
        staged = ctx.memo.get("spot_data") or mujoco.MjData(scene.model)
        ctx.memo["spot_data"] = staged
        staged.qpos[:] = scene.data.qpos
        adr = int(scene.model.jnt_qposadr[scene.model.body_jntadr[scene.object_body(role)]])
        staged.qpos[adr:adr + 3], staged.qpos[adr + 3:adr + 7] = at.pos, at.quat
        staged.qpos[scene.articulation_qpos_adr(CABINET)] = self.stroke(ctx)
        planner.sync(staged)
        try:
            checker = planner.checker
            checker.configure(AllowedContacts(), None, float(ctx.param("clear_arm_margin")))
            for q in later:
                if any(c.body2.split("/")[0] == role for c in checker.collisions(q)):
                    return False
            if role == TARGET:
                return self._target_reachable_at(ctx, at)
            return True
        finally:
            planner.sync(scene.data)

    def _target_reachable_at(self, ctx: Context, at: Pose) -> bool:
        """Whether the target's chosen grasp reaches it standing at ``at`` (pre-grasp and grasp
        collision-free, in the planner's current state)."""
        rng = np.random.default_rng(np.random.SeedSequence([ctx.task.seed, 0x5B08]))
        touch = AllowedContacts(((ROOT_BODY, TARGET),))
        pose = at @ Pose.from_matrix(ctx.memo["grasp"].matrix())
        pre = Pose(pose.pos - pose.rotation()[:, 2] * float(ctx.variation["grasp_standoff"]), pose.quat)
        try:
            q = ctx.planner.ik(pre, ctx.q_cmd, rng, collision_free=True, allowed=touch)
            ctx.planner.ik(pose, q, rng, collision_free=True, allowed=touch)
        except MotionFailure:
            return False
        return True

    @staticmethod
    def _yaw_only(quat: np.ndarray) -> np.ndarray:
        """The rotation about world +Z closest to ``quat`` (the object stood upright again)."""
        rot = Pose(np.zeros(3), quat).rotation()
        yaw = math.atan2(rot[1, 0], rot[0, 0])
        return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])

    def _drawer_target(self, ctx: Context) -> tuple[Pose, Pose]:
        """TCP poses over the drawer's opening and down in it, for the held target (computed once)."""
        if "drawer_tcp" in ctx.memo:
            return ctx.memo["drawer_tcp"]
        cab, geo = self._cabinet(ctx)
        rot = cab.rotation()
        q = self.drawer_q(ctx)
        hxi, hyi, depth = (float(v) for v in geo["drawer_inner"])
        lo_x, hi_x = float(geo["front_x"]) - q, hxi  # the open part of the interior (drawer frame, along x)
        floor = float(geo["drawer_floor_z"])
        rim = floor + depth
        size = np.asarray(ctx.scene.object_model(TARGET).size)
        tcp_t_obj, held = self._held(ctx, TARGET)
        obj = ctx.object_pose(TARGET)
        base = Pose(np.zeros(3), self._yaw_only(obj.quat))
        rng = ctx.variation.rng("drawer")
        margin = float(ctx.param("put_drop"))
        why = f"the opening is {(hi_x - lo_x) * 100:.1f} cm"
        for outward, yaw in itertools.product((False, True), ctx.param("drawer_yaws_deg")):
            half = math.radians(float(yaw)) / 2.0
            turned = (Pose(np.zeros(3), [math.cos(half), 0.0, 0.0, math.sin(half)]) @ base).quat
            r_local = rot.T @ Pose(np.zeros(3), turned).rotation()  # object axes in the cabinet frame
            half_x = float(np.abs(r_local[0, :2]) @ (size[:2] / 2))
            half_y = float(np.abs(r_local[1, :2]) @ (size[:2] / 2))
            slack = 0.5 * (hi_x - lo_x) - half_x - margin
            if slack < 0.0 or (outward and slack < 0.005):
                continue
            # the middle of the opening, else its outer end (the wrist then keeps farther from the carcass)
            cx = 0.5 * (lo_x + hi_x) + (slack if outward else 0.0) + q  # cabinet frame
            cy = float(np.clip(ctx.variation["drawer_dx"], -hyi + half_y + margin, hyi - half_y - margin))
            centre = cab.pos + rot @ np.array([cx, cy, 0.0])
            low = Pose(np.array([centre[0], centre[1], cab.pos[2] + floor + margin]), turned)
            high = Pose(low.pos + np.array([0.0, 0.0, rim + float(ctx.param("rim_clear")) - floor - margin]),
                        turned)
            down, above = low @ tcp_t_obj.inverse(), high @ tcp_t_obj.inverse()
            try:  # over the opening, and the line down into the drawer as the executor plans it
                q_above = ctx.planner.ik(above, ctx.q_cmd, rng, collision_free=True, attached=held)
                ctx.planner.line(q_above, down, rng, allowed=AllowedContacts(((TARGET, CABINET),)),
                                 attached=held)
            except MotionFailure as fail:
                why = fail.reason
                continue
            ctx.memo["drawer_tcp"] = (above, down)
            return above, down
        yaws = list(ctx.param("drawer_yaws_deg"))
        raise AttemptFailed("target_fail", f"no turn of the target ({yaws} deg) fits the drawer's opening "
                                           f"and is reachable ({why})")

    # -- the initial-state gate ------------------------------------------------------------------------------
    def _reachable_open(self, ctx: Context) -> tuple[Grasp, ...]:
        """The target's reachable grasps with the drawer opened to the stroke (as when it is picked, after the
        blockers were moved: the obstacle, if relocated, does not count)."""
        scene = ctx.scene
        adr = scene.articulation_qpos_adr(CABINET)
        closed = float(scene.data.qpos[adr])
        moved = AllowedContacts(tuple(p for p in self.moved_first(ctx).pairs if p[1] != TARGET))
        scene.data.qpos[adr] = self.stroke(ctx)
        mujoco.mj_forward(scene.model, scene.data)
        try:
            ctx.planner.sync(scene.data)
            return self.target.reachable_grasps(ctx, moved)
        finally:
            scene.data.qpos[adr] = closed
            mujoco.mj_forward(scene.model, scene.data)
            ctx.planner.sync(scene.data)

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """The target fits under the drawer's rim; a handle grasp is reachable closed and pulled open; the
        target (and each blocker) has enough reachable grasps."""
        _, geo = self._cabinet(ctx)
        room = float(geo["drawer_inner"][2]) - float(ctx.param("fit_clearance"))
        tall = float(ctx.scene.object_model(TARGET).size[2])
        if tall > room:
            raise Infeasible("fit.height", f"the target is {tall * 100:.1f} cm tall; the drawer takes "
                                           f"{room * 100:.1f} cm")
        handles = self.handle_grasps(ctx)
        if not handles:
            raise Infeasible("reach.handle", "no valid handle grasp is reachable at both ends of the stroke")
        facts: dict[str, object] = {"handle_grasps": tuple(g.id for g in handles)}
        targets = self._reachable_open(ctx)
        if len(targets) < max(min_grasps, 1):
            raise Infeasible("reach.grasps", f"{len(targets)} of the {len(ctx.grasps.get(TARGET, ()))} valid "
                                             f"grasps of the target are reachable (needs {min_grasps})")
        facts["grasps"] = tuple(g.id for g in targets)
        for role in self.in_the_way(ctx):
            mover = self._mover(role)
            found = mover.reachable_grasps(ctx)
            if not found:
                raise Infeasible("reach.blocker", f"the {role} is in the drawer's way and none of its grasps "
                                                  "is reachable")
            facts[f"{mover.tag}grasps"] = tuple(g.id for g in found)
        facts["in_the_way"] = tuple(self.in_the_way(ctx))
        return facts
