"""Jar: close the hinged jar's lid, then carry the closed jar into the goal sphere.

The motion, as the paper describes it:

1. **Close the lid.** The open lid leans past vertical towards the robot. With the gripper closed, the
   fingers come down behind the lid, push it away from the robot until it is past vertical the other way,
   wait for the arm to catch up, and back off along the same line; gravity swings the lid shut.
2. **Carry the jar.** Open the gripper, side-grasp the jar (a valid grasp from the grasp DB, round-robin over
   the reachable ones), lift it, carry it so that its centre (the centre of its bounding volume) lands in the
   goal sphere, stop, and hold it there. The gate counts only this final hold: the arm commanded still, the
   jar at rest in the goal. The carry aims the centre at most ``goal_dx``/``goal_dy`` (1.2 cm each) from the
   goal centre; the servos sag 2.5–15 mm (mostly down) under the jar's weight, so the settled centre lies
   0.4–1.9 cm from the goal centre (50 carries measured, goal radius 5 cm; docs/generate.md).

Numbers come from ``recipes/jar.toml``: per-attempt draws in ``[variation]``, fixed tunables in ``[params]``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mgdata.engine import segment as s
from mgdata.engine.context import Context
from mgdata.engine.gate import AttemptFailed
from mgdata.engine.skeleton import FamilySkeleton, Knob, Param, RecipeKeys, register
from mgdata.grasps.db import Grasp
from mgdata.motion import AllowedContacts, Attachment, MotionFailure, Pose

TOUCH_JAR = (("hand", "jar"),)
LIFTING_JAR = (("hand", "jar"), ("jar", "table"), ("jar", "food"), ("base", "food"))
CARRYING_JAR = (("hand", "jar"), ("jar", "food"), ("base", "food"))
"""Allowed contacts: the food rides inside the held jar; the planner's static copy of it is no obstacle."""


@register
class JarSkeleton(FamilySkeleton):
    """The jar family's demonstration (see the module docstring)."""

    family = "jar"
    recipe_keys = RecipeKeys(
        params=(
            Param("lid_push_clear", float, "m between fingers and the open lid's back face at the push start",
                  0.0, 0.1),
            Param("lid_finger_depth", float, "m from the TCP to the fingers' pushing face, along the push",
                  0.0, 0.05),
            Param("fingertip_below_tcp", float, "m the fingertips reach past the TCP", 0.0, 0.05),
            Param("palm_depth", float, "m from the TCP back to the palm", 0.0, 0.1),
            Param("lid_palm_clear", float, "m kept between the palm and the lid's top edge while pushing",
                  0.0, 0.1),
            Param("lid_descend", float, "m the fingers descend to the push height from above", 0.0, 0.3),
            Param("lid_settle_steps", int, "control steps holding the push's end", 0, 200),
            Param("open_steps", int, "control steps to open the gripper", 1, 200),
            Param("grasp_settle_steps", int, "control steps holding the grasp pose before closing", 0, 200),
            Param("close_steps", int, "control steps to close the gripper on the jar", 1, 200),
            Param("carry_speed", float, "fraction of the planned speed while carrying the jar", 0.01, 1.0),
            Param("goal_hold_steps", int, "control steps holding the jar in the goal", 1, 2000),
            Param("grasp_margin", float, "rad every joint of a reachable grasp keeps from its limits",
                  0.0, 1.0),
            Param("grasp_clearance", float, "m a reachable grasp keeps the arm from all but the jar",
                  0.0, 0.05),
            Param("reach_standoff", float, "m pre-grasp standoff used to test which grasps are reachable",
                  0.0, 0.3),
            Param("carry_yaws_deg", tuple, "turns of the jar about the vertical tried for the goal (deg)",
                  -180.0, 180.0),
        ),
        variation=(
            Knob("lid_push_frac", "push point above the hinge, as a fraction of the lid's length", 0.0, 1.0),
            Knob("lid_push_past", "degrees past vertical at which the push stops", 0.0, 60.0),
            Knob("grasp_standoff", "m back along the approach axis for the pre-grasp pose", 0.0, 0.3),
            Knob("grasp_height", "m offset of the grasp along the jar axis", -0.05, 0.05),
            Knob("lift_height", "m the jar's bottom is lifted above the table before carrying", 0.0, 0.3),
            Knob("goal_dx", "m offset of the carried jar's centre from the goal centre along x", -0.05, 0.05),
            Knob("goal_dy", "m offset of the carried jar's centre from the goal centre along y", -0.05, 0.05),
        ),
    )

    def __init__(self) -> None:
        self._reachable: dict[int, tuple[Grasp, ...]] = {}

    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        p = ctx.params
        self._choose_grasp(ctx)
        return [
            s.free("lid_above", "lid_above", gripper="close"),
            s.linear("lid_descend", "lid_start", gripper="close"),
            s.linear("lid_push", "lid_end", gripper="close", allow=TOUCH_JAR),
            s.hold("lid_settle", steps=int(p["lid_settle_steps"]), gripper="close"),
            s.reverse("lid_back", of="lid_push", gripper="close", allow=TOUCH_JAR),
            s.gripper("open", "open", steps=int(p["open_steps"])),
            s.free("pre_grasp", "pre_grasp"),
            s.linear("approach", "grasp", allow=TOUCH_JAR),
            s.hold("grasp_settle", steps=int(p["grasp_settle_steps"])),
            s.gripper("close", "close", steps=int(p["close_steps"])),
            s.linear("lift", "lift", gripper="close", attached="jar", allow=LIFTING_JAR),
            s.free("carry", "goal", gripper="close", attached="jar", allow=CARRYING_JAR,
                   speed=float(p["carry_speed"])),
            s.hold("hold", steps=int(p["goal_hold_steps"]), gripper="close"),
        ]

    # -- runtime targets ---------------------------------------------------------------------------------
    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.startswith("lid_"):
            return self._lid_target(name, ctx)
        if name in ("pre_grasp", "grasp"):
            grasp = self._grasp_pose(ctx)
            if name == "grasp":
                return grasp
            back = grasp.rotation()[:, 2] * ctx.variation["grasp_standoff"]
            return Pose(grasp.pos - back, grasp.quat)
        if name == "lift":
            tcp = ctx.commanded_tcp()
            return Pose(tcp.pos + np.array([0.0, 0.0, ctx.variation["lift_height"]]), tcp.quat)
        if name == "goal":
            return self._goal_target(ctx)
        return super().resolve(name, ctx)

    def _lid_target(self, name: str, ctx: Context) -> Pose:
        """Fingertip line behind the open lid, from the hinge geometry and the lid's current angle."""
        geo = ctx.scene.object_model("jar").geometry
        jar = ctx.object_pose("jar")
        rot = jar.rotation()
        hinge = jar.pos + rot @ np.asarray(geo["hinge_pos"])
        along = rot[:, 0]  # jar +X: from the hinge across the jar, away from the robot
        theta0 = ctx.scene.articulation_fraction("jar") * geo["open_angle"]
        if theta0 <= math.pi / 2:
            raise AttemptFailed("target_fail", f"the lid is not past vertical ({math.degrees(theta0):.0f}°); "
                                "the push-from-behind closing needs it leaning towards the robot")
        half_t, length = geo["lid_thickness"] / 2.0, 2.0 * geo["lid_radius"]
        # Push at a fraction of the lid's length, but high enough that the palm clears the lid's top edge.
        palm_low = length + float(ctx.param("lid_palm_clear")) - float(ctx.param("palm_depth"))
        height = max(ctx.variation["lid_push_frac"] * length, palm_low)
        depth = float(ctx.param("lid_finger_depth"))
        if name in ("lid_above", "lid_start"):
            back_face = length * math.cos(theta0) - half_t * math.sin(theta0)  # top edge, nearest the robot
            x = back_face - float(ctx.param("lid_push_clear")) - depth
            z = height + (float(ctx.param("lid_descend")) if name == "lid_above" else 0.0)
        elif name == "lid_end":
            end = math.pi / 2 - math.radians(ctx.variation["lid_push_past"])
            tip = height - float(ctx.param("fingertip_below_tcp"))
            x = tip / math.tan(end) - half_t / math.sin(end) - depth
            z = height
        else:
            return super().resolve(name, ctx)
        return Pose(hinge + along * x + np.array([0.0, 0.0, z]), self._push_quat(ctx, rot[:, 1]))

    @staticmethod
    def _push_quat(ctx: Context, hinge_axis: np.ndarray) -> np.ndarray:
        """Gripper pointing down, fingers side by side along the hinge (the roll nearest the current one)."""
        current = ctx.commanded_tcp()
        best = None
        for sign in (1.0, -1.0):
            y = sign * hinge_axis / np.linalg.norm(hinge_axis)
            z = np.array([0.0, 0.0, -1.0])
            pose = Pose.from_pos_mat(np.zeros(3), np.stack([np.cross(y, z), y, z], axis=1))
            if best is None or pose.angle_to(current) < best.angle_to(current):
                best = pose
        assert best is not None
        return best.quat

    # -- grasping ----------------------------------------------------------------------------------------
    def _choose_grasp(self, ctx: Context) -> None:
        """Pick this attempt's grasp round-robin over the task's reachable valid grasps (start state)."""
        task_id = ctx.task.task_id
        if task_id not in self._reachable:
            self._reachable[task_id] = self._reachable_grasps(ctx)
        reachable = self._reachable[task_id]
        if not reachable:
            model, n = ctx.task.object("jar").model, len(ctx.grasps.get("jar", ()))
            why = (f"none of the {n} valid grasps of {model} is reachable from here" if n else
                   f"{model} has no valid grasps: run `mgdata grasps generate` then `mgdata grasps validate`")
            raise AttemptFailed("no_grasp", why)
        grasp = reachable[ctx.variation.pick(len(reachable))]
        ctx.memo["grasp"] = grasp
        ctx.memo["grasp_id"] = grasp.id

    def _reachable_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        """Valid grasps whose pre-grasp and grasp poses have IK solutions with joint-limit margin and with
        the arm ``grasp_clearance`` clear of everything but the jar (a wrist that grazes the table in the plan
        hits it once the servos sag, and the grasp misses).

        Evaluated once per task from the start state with a task-derived seed, so every worker agrees.
        """
        jar = ctx.object_pose("jar").matrix()
        margin = float(ctx.param("grasp_margin"))
        checker = ctx.planner.checker
        checker.configure(AllowedContacts((("base", "jar"),)), None, float(ctx.param("grasp_clearance")))
        standoff = float(ctx.param("reach_standoff"))
        rng = np.random.default_rng(np.random.SeedSequence([ctx.task.seed, 0x9A5]))
        out = []
        for grasp in ctx.grasps.get("jar", ()):
            pose = Pose.from_matrix(jar @ grasp.matrix())
            pre = Pose(pose.pos - pose.rotation()[:, 2] * standoff, pose.quat)
            try:
                q_pre = ctx.planner.ik(pre, ctx.q_cmd, rng)
                q = ctx.planner.ik(pose, q_pre, rng)
            except MotionFailure:
                continue
            room = min(np.min(q - ctx.planner.lower), np.min(ctx.planner.upper - q),
                       np.min(q_pre - ctx.planner.lower), np.min(ctx.planner.upper - q_pre))
            if room >= margin and checker.valid(q) and checker.valid(q_pre):
                out.append(grasp)
        return tuple(out)

    def _grasp_pose(self, ctx: Context) -> Pose:
        grasp: Grasp = ctx.memo["grasp"]
        jar = ctx.object_pose("jar").matrix()
        local = grasp.matrix()
        local[2, 3] += ctx.variation["grasp_height"]
        return Pose.from_matrix(jar @ local)

    def _goal_target(self, ctx: Context) -> Pose:
        """TCP pose that puts the held jar's centre at the goal centre (offset by the draw), the jar turned
        about the vertical by the first of ``carry_yaws_deg`` the arm can reach (the jar stays upright)."""
        goal = ctx.task.goal
        if goal is None:
            raise AttemptFailed("target_fail", "the jar task has no goal region")
        geo = ctx.scene.object_model("jar").geometry
        jar = ctx.object_pose("jar")
        tcp_t_jar = ctx.tcp_pose().inverse() @ jar
        held = Attachment("jar", tcp_t_jar.matrix())
        centre_local = np.array([0.0, 0.0, geo["total_height"] / 2.0])
        centre = np.asarray(goal.pos) + np.array([ctx.variation["goal_dx"], ctx.variation["goal_dy"], 0.0])
        rng = ctx.variation.rng("carry_yaw")
        first = None
        for yaw in ctx.param("carry_yaws_deg"):
            half = math.radians(yaw) / 2.0
            turn = Pose(np.zeros(3), [math.cos(half), 0.0, 0.0, math.sin(half)])
            rot = (turn @ Pose(np.zeros(3), jar.quat)).quat
            target_jar = Pose(centre - Pose(np.zeros(3), rot).rotation() @ centre_local, rot)
            target = target_jar @ tcp_t_jar.inverse()
            first = first or target
            try:
                ctx.planner.ik(target, ctx.q_cmd, rng, collision_free=True,
                               allowed=AllowedContacts(CARRYING_JAR), attached=held)
            except MotionFailure:
                continue
            return target
        assert first is not None
        return first
