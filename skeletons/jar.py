"""Jar: close the hinged jar's lid, then carry the closed jar into the goal sphere.

The motion, as the paper describes it:

1. **Close the lid** (phase ``close_lid``, done once ``jar_closed`` holds). The open lid leans past
   vertical towards the robot. With the gripper closed, the fingers come down behind the lid, push it away
   from the robot until it is past vertical the other way, wait for the arm to catch up, and back off along
   the same line; gravity swings the lid shut.
2. **Carry the jar** (phase ``carry``; Layer 2's pick-and-carry, the food riding inside): side-grasp the
   jar (round-robin over its reachable valid grasps), lift it, carry it over the goal, lower its centre into
   the goal sphere and hold it there. The carry aims the centre at most ``goal_dx``/``goal_dy`` (1.2 cm
   each) from the goal centre; the servos sag 2.5–15 mm (mostly down) under the jar's weight
   (docs/generate.md).

Numbers come from ``recipes/jar.toml``: per-attempt draws in ``[variation]``, fixed tunables in ``[params]``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.motion import Pose
from mgdata.sim.robot import FINGERTIP_REACH, PALM_DEPTH
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.phase import Phase
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.skeleton import FamilySkeleton, Knob, Param, RecipeKeys, register

TOUCH_JAR = (("hand", "jar"),)


@register
class JarSkeleton(FamilySkeleton):
    """The jar family's demonstration (see the module docstring)."""

    name = "jar"
    recipe_keys = PICK_AND_CARRY_KEYS + RecipeKeys(
        params=(
            Param("lid_push_clear", float, "m between fingers and the open lid's back face at the push start",
                  0.0, 0.1),
            Param("lid_finger_depth", float, "m from the TCP to the fingers' pushing face, along the push",
                  0.0, 0.05),
            Param("lid_palm_clear", float, "m kept between the palm and the lid's top edge while pushing",
                  0.0, 0.1),
            Param("lid_descend", float, "m the fingers descend to the push height from above", 0.0, 0.3),
            Param("lid_settle_steps", int, "control steps holding the push's end", 0, 200),
        ),
        variation=(
            Knob("lid_push_frac", "push point above the hinge, as a fraction of the lid's length", 0.0, 1.0),
            Knob("lid_push_past", "degrees past vertical at which the push stops", 0.0, 60.0),
        ),
    )
    carry = PickAndCarry("jar", riders=("food",))

    def phases(self, ctx: Context) -> Sequence[Phase]:
        return [Phase("close_lid", self._close_lid(ctx), done="jar_closed"),
                Phase("carry", tuple(self.carry.segments(ctx)))]

    @staticmethod
    def _close_lid(ctx: Context) -> tuple[s.MotionSegment, ...]:
        return (
            s.free("lid_above", "lid_above", gripper="close"),
            s.linear("lid_descend", "lid_start", gripper="close"),
            s.linear("lid_push", "lid_end", gripper="close", allow=TOUCH_JAR),
            s.hold("lid_settle", steps=ctx.params["lid_settle_steps"], gripper="close"),
            s.reverse("lid_back", of="lid_push", gripper="close", allow=TOUCH_JAR),
        )

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        return self.carry.feasibility(ctx, min_grasps)

    # -- runtime targets ---------------------------------------------------------------------------------
    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.startswith("lid_"):
            return self._lid_target(name, ctx)
        return self.carry.resolve(name, ctx) or super().resolve(name, ctx)

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
        palm_low = length + ctx.param("lid_palm_clear") - PALM_DEPTH
        height = max(ctx.variation["lid_push_frac"] * length, palm_low)
        depth = ctx.param("lid_finger_depth")
        if name in ("lid_above", "lid_start"):
            back_face = length * math.cos(theta0) - half_t * math.sin(theta0)  # top edge, nearest the robot
            x = back_face - ctx.param("lid_push_clear") - depth
            z = height + (ctx.param("lid_descend") if name == "lid_above" else 0.0)
        elif name == "lid_end":
            end = math.pi / 2 - math.radians(ctx.variation["lid_push_past"])
            tip = height - FINGERTIP_REACH
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
