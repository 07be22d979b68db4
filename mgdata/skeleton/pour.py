"""Pouring from a held carrier (a bowl) into a destination tray: carry it to the pour stance, tilt it in
steps, hold while what it carries falls and settles.

The stance (:meth:`Pour.plan`): the hand turned about the vertical as carried, or so that the grasp's radius
points away from the robot (or half way), or by ``pour_turns_deg``; the tilt lowers the rim opposite the
hand, or one ``pour_axis_turns_deg`` round from it; the carrier's mouth, at the final tilt, over the tray's
cavity (its centre, then ``pour_aim_offsets``), its outline ``pour_clearance`` above the rim at every step.
The tilt is the drawn ``pour_angle_deg`` but at least ``pour_slide_margin_deg`` past the tilt at which the
food slides out (:func:`slide_tilt`), else 10° or 20° more. The first stance whose every step the arm
reaches collision-free (:func:`tilt_chain`) is taken, its solutions seeding the segments' IK.

Segments: ``carry`` (free, to ``pour_start``), ``pour_0`` … ``pour_{n-1}`` (straight turns about the TCP up
to ``pour_line_deg``, joint-space beyond), ``pour_settle``. A skeleton declares :data:`POUR_KEYS` and the knob
:data:`POUR_KNOB`::

    pour = Pour("source", food="food", dest="dest")
    segs = pour.segments(ctx)
    pose = pour.target(name, ctx)          # for names in pour.names(ctx)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.motion import AllowedContacts, Attachment, MotionFailure, Pose
from mgdata.sim.assets.model import ObjectModel
from mgdata.sim.geometry import box_corners
from mgdata.sim.robot import ROOT_BODY
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import UP, rotation_about
from mgdata.tasks.recipe_keys import Knob, Param, RecipeKeys

POUR_KEYS = RecipeKeys(params=(
    Param("pour_steps", int, "turns the tilt is split into", 1, 50),
    Param("pour_speed", float, "fraction of the planned speed while tilting", 0.01, 1.0),
    Param("pour_line_deg", float, "tilts up to this are straight turns about the TCP; beyond, "
          "joint-space moves (the wrist passes a singularity near 90°)", 0.0, 180.0),
    Param("pour_aim_offsets", tuple, "m (x, y pairs in the tray's frame) of the other points "
          "the mouth may pour over if the centre's stance is out of reach", -0.2, 0.2),
    Param("pour_clearance", float, "m the tilted bowl's outline keeps above the tray's rim", 0.0, 0.3),
    Param("pour_max_joint_change", float, "rad a joint may move in one tilt step", 0.1, 6.3),
    Param("pour_turns_deg", tuple, "deg: further turns of the hand about the vertical the "
          "pour stance may take (after none, the one putting the grasp away from the robot and "
          "half of it)", -180.0, 180.0),
    Param("pour_axis_turns_deg", tuple, "deg: turns about the vertical of the tilt axis from "
          "the one lowering the rim opposite the hand, tried in order (a round carrier pours "
          "over any rim point alike)", -90.0, 90.0),
    Param("pour_slide_margin_deg", float, "deg the final tilt keeps past the one at which the "
          "food slides off the carrier's lowest wall", 0.0, 60.0),
    Param("pour_hold_steps", int, "control steps holding the tilt while the food settles", 1, 2000),
))
"""The recipe keys a pour reads (and ``carry_speed``, a pick-and-carry key)."""
POUR_KNOB = Knob("pour_angle_deg", "final tilt of the carrier (deg)", 30.0, 150.0)
"""The variation knob a pour reads (declared by the skeleton, in its own order)."""


def outline(model: ObjectModel) -> np.ndarray:
    """Points (n, 3, local frame) bounding a carrier: its foot and rim circles (16 points each) if it is
    round, else its bounding box's corners."""
    geo = model.geometry
    if "rim_radius" in geo and "bottom_radius" in geo:
        phi = np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)
        ring = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(16)])
        return np.concatenate([ring * float(geo["bottom_radius"]),
                               ring * float(geo["rim_radius"]) + [0.0, 0.0, float(geo["height"])]])
    lo = np.array([-model.size[0] / 2, -model.size[1] / 2, 0.0])
    return box_corners(lo, np.array([model.size[0] / 2, model.size[1] / 2, model.size[2]]))


def slide_tilt(ctx: Any, carrier: str = "source", food: str = "food") -> float:
    """Tilt (rad) of the carrier at which the food slides out along its lowest wall: the wall's slope below
    the horizontal, ``tilt - 90° + flare`` (the wall's angle from the carrier's axis; 0 for a box), exceeds
    the friction angle ``atan(mu)``, ``mu`` the larger sliding friction of the two objects' geoms (MuJoCo's
    default contact mixing). ``ctx``: anything with a ``scene``."""
    geo = ctx.scene.object_model(carrier).geometry
    flare = 0.0
    if "rim_radius" in geo and "bottom_radius" in geo:
        flare = math.atan2(float(geo["rim_radius"]) - float(geo["bottom_radius"]), float(geo["height"]))
    m = ctx.scene.model
    roots = {m.body(carrier).id, m.body(food).id}
    mu = max(float(m.geom_friction[g, 0]) for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] in roots)
    return math.pi / 2 - flare + math.atan(mu)


def tilt_chain(ctx: Context, pos: np.ndarray, turns: list[np.ndarray], rng: np.random.Generator,
               allowed: AllowedContacts, held: Attachment) -> list[np.ndarray] | None:
    """Arm configurations holding the TCP at ``pos`` turned by each of ``turns`` (collision-free holding the
    carrier), or None if one is out of reach or a tilt step would move a joint more than
    ``pour_max_joint_change`` (another IK branch: the arm would swing round). Solved from the level stance
    on, each turn from the last one's solution; failing that, from the last turn back, so that the most
    tilted pose, the hardest to reach, picks the arm's branch."""
    limit = ctx.param("pour_max_joint_change")
    for order in (turns, turns[::-1]):
        q, qs = ctx.q_cmd, []
        for r in order:
            try:
                q_next = ctx.planner.ik(Pose.from_pos_mat(pos, r), q, rng, collision_free=True,
                                        allowed=allowed, attached=held)
            except MotionFailure:
                break
            if qs and float(np.max(np.abs(q_next - q))) > limit:
                break
            q = q_next
            qs.append(q)
        else:
            return qs if order is turns else qs[::-1]
    return None


@dataclass(frozen=True)
class Pour:
    """Pour the held ``carrier``'s ``food`` into ``dest`` (see the module docstring)."""

    carrier: str
    food: str
    dest: str

    def names(self, ctx: Context) -> tuple[str, ...]:
        """Its runtime targets: the stance, then one per tilt step."""
        return ("pour_start", *(f"pour_{k}" for k in range(ctx.params["pour_steps"])))

    def segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Carry to the stance, tilt step by step, hold."""
        p = ctx.params
        n, angle = p["pour_steps"], ctx.variation[POUR_KNOB.name]
        riders, speed = (self.food,), p["pour_speed"]
        tilt = [s.linear(name, name, orientation="slerp", gripper="close", attached=self.carrier,
                         riders=riders, speed=speed)
                if angle * (k + 1) / n <= p["pour_line_deg"]
                else s.free(name, name, gripper="close", attached=self.carrier, riders=riders, speed=speed)
                for k, name in enumerate(self.names(ctx)[1:])]
        return [s.free("carry", "pour_start", gripper="close", attached=self.carrier, riders=riders,
                       speed=p["carry_speed"]),
                *tilt,
                s.hold("pour_settle", steps=p["pour_hold_steps"], gripper="close")]

    def target(self, name: str, ctx: Context) -> Pose:
        """Runtime target ``name`` (one of :meth:`names`), from the stance planned when first asked."""
        if "pour" not in ctx.memo:
            ctx.memo["pour"] = self.plan(ctx)
        pos, quat0, axis, angle = ctx.memo["pour"]
        k = self.names(ctx).index(name)  # 0: the stance, k: after the k-th tilt step
        if k == 0:
            return Pose(pos, quat0)
        turn = rotation_about(axis, angle * k / ctx.param("pour_steps"))
        return Pose.from_pos_mat(pos, turn @ Pose(pos, quat0).rotation())

    def plan(self, ctx: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The pour stance: TCP position, level orientation, tilt axis and angle (see the module
        docstring); its IK solutions become the segments' seeds (``ctx.q_hints``). None reachable ends the
        attempt (``target_fail``)."""
        tcp, bowl = ctx.commanded_tcp(), ctx.object_pose(self.carrier)
        in_tcp = tcp.inverse() @ bowl
        radial = tcp.pos - bowl.pos
        radial[2] = 0.0
        if np.linalg.norm(radial) < 1e-4:
            raise AttemptFailed("target_fail", "the carrier is held at its axis: no side to pour over")
        radial /= np.linalg.norm(radial)
        model = ctx.scene.object_model(self.carrier)
        corners, mouth = outline(model), np.array([0.0, 0.0, model.size[2]])
        tray, cavity = ctx.object_pose(self.dest), ctx.scene.object_model(self.dest).cavity
        assert cavity is not None
        n, rot0 = ctx.param("pour_steps"), tcp.rotation()
        loose = ctx.scene.loose_bodies(self.food)
        held = Attachment(self.carrier, in_tcp.matrix(), riders=tuple(loose))
        allowed = AllowedContacts(tuple((ROOT_BODY, b) for b in loose))
        rng = ctx.variation.rng("pour_stance")
        offsets = [(0.0, 0.0), *((float(a), float(b)) for a, b in
                                 np.asarray(ctx.param("pour_aim_offsets")).reshape(-1, 2))]
        away = tray.pos - ctx.scene.data.xpos[ctx.scene.model.body(ROOT_BODY).id]
        facing = math.atan2(away[1], away[0]) - math.atan2(radial[1], radial[0])
        facing = math.atan2(math.sin(facing), math.cos(facing))  # turn putting the radial away from the robot
        yaws = (0.0, facing, facing / 2) if abs(facing) > math.radians(10.0) else (0.0,)
        yaws += tuple(math.radians(a) for a in ctx.param("pour_turns_deg"))
        betas = tuple(math.radians(b) for b in ctx.param("pour_axis_turns_deg"))
        least = math.degrees(slide_tilt(ctx, self.carrier, self.food)) + ctx.param("pour_slide_margin_deg")
        first = max(ctx.variation[POUR_KNOB.name], least)
        for angle in (math.radians(min(first + d, 150.0)) for d in (0.0, 10.0, 20.0)):
            for beta, yaw in ((b, y) for b in betas for y in yaws):
                level = rotation_about(UP, yaw) @ rot0
                axis = np.cross(rotation_about(UP, yaw) @ radial, UP)  # turning about it lowers the far rim
                axis = rotation_about(UP, beta) @ axis  # … or the rim ``beta`` round from it
                turns = [rotation_about(axis, angle * k / n) @ level for k in range(n + 1)]
                low = min(float(np.min((r @ in_tcp.pos + corners @ (r @ in_tcp.rotation()).T)[:, 2]))
                          for r in turns)
                mouth_off = turns[-1] @ in_tcp.pos + (turns[-1] @ in_tcp.rotation()) @ mouth
                for dx, dy in offsets:
                    aim = tray.pos + tray.rotation() @ np.array([dx, dy, cavity.rim_z])
                    pos = np.array([aim[0] - mouth_off[0], aim[1] - mouth_off[1],
                                    aim[2] + ctx.param("pour_clearance") - low])
                    qs = tilt_chain(ctx, pos, turns, rng, allowed, held)
                    if qs is None:
                        continue
                    ctx.q_hints.update(zip(self.names(ctx), qs, strict=True))
                    return pos, Pose.from_pos_mat(pos, level).quat, axis, angle
        raise AttemptFailed("target_fail", f"no pour stance over the tray is reachable holding the bowl "
                            f"({len(offsets)} aim points, {len(yaws)} turns, {len(betas)} tilt axes; "
                            f"{first:.0f}°, 10° and 20° more)")
