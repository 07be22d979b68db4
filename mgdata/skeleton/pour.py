"""Pouring from a held carrier (a bowl or a tray) into a destination tray: carry it to the pour stance, tilt
it in steps, hold while what it carries falls and settles.

The stance (:meth:`Pour.plan`): the hand turned about the vertical as carried, or so that the grasp's radius
points away from the robot (or half way), or by ``pour_turns_deg``; the tilt lowers the rim opposite the
hand, or one ``pour_axis_turns_deg`` round from it; the carrier's mouth, at the final tilt, over the tray's
cavity (its centre, then ``pour_aim_offsets``), its outline ``pour_clearance`` above the rim at every step,
the stance raised by each of ``pour_lifts`` in turn. A flat carrier (a tray, :meth:`Pour.flat`) turns
instead about the top edge of its wall opposite the hand, held over the aim point (the food leaves over
that edge, at whatever tilt it slides), its hand turned towards the robot rather than away (it rises away
from the robot over the edge), and only over that wall.
The tilt is the drawn ``pour_angle_deg`` but at least ``pour_slide_margin_deg`` past the tilt at which the
food slides out (:func:`slide_tilt`), else 10° or 20° more. The first stance that the level carry reaches
and whose every step the arm then reaches collision-free, on the carry's branch (:func:`tilt_chain`), is
taken, its solutions seeding the segments' IK.

Segments: ``carry`` (to ``pour_start``: a bowl in joint space; a tray in a straight line, level, only turned
about the vertical, since a joint-space carry tips it and the food slides off), ``pour_0`` …
``pour_{n-1}`` (straight turns about the TCP up to ``pour_line_deg``, joint-space beyond), ``pour_settle``.
A skeleton declares :data:`POUR_KEYS` and the knob :data:`POUR_KNOB`::

    pour = Pour("source", food="food", dest="dest")
    segs = pour.segments(ctx)
    pose = pour.target(name, ctx)          # for names in pour.names(ctx)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
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
    Param("pour_lifts", tuple, "m the stance may rise further above the lowest one (for each, every aim "
          "point is tried; a tray turned about its edge needs room for the wrist below the hand)", 0.0, 0.5,
          default=(0.0,)),
))
"""The recipe keys a pour reads (and ``carry_speed``, a pick-and-carry key)."""
POUR_KNOB = Knob("pour_angle_deg", "final tilt of the carrier (deg)", 30.0, 150.0)
"""The variation knob a pour reads (declared by the skeleton, in its own order)."""


def is_round(model: ObjectModel) -> bool:
    """Is the carrier round (a bowl: foot and rim radii), not flat (a tray)?"""
    return "rim_radius" in model.geometry and "bottom_radius" in model.geometry


def outline(model: ObjectModel) -> np.ndarray:
    """Points (n, 3, local frame) bounding a carrier: its foot and rim circles (16 points each) if it is
    round, else its bounding box's corners."""
    geo = model.geometry
    if is_round(model):
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
    model = ctx.scene.object_model(carrier)
    geo, flare = model.geometry, 0.0
    if is_round(model):
        flare = math.atan2(float(geo["rim_radius"]) - float(geo["bottom_radius"]), float(geo["height"]))
    m = ctx.scene.model
    roots = {m.body(carrier).id, m.body(food).id}
    mu = max(float(m.geom_friction[g, 0]) for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] in roots)
    return math.pi / 2 - flare + math.atan(mu)


def tilt_chain(ctx: Context, poses: list[Pose], rng: np.random.Generator, allowed: AllowedContacts,
               held: Attachment, q0: np.ndarray | None = None) -> list[np.ndarray] | None:
    """Arm configurations putting the TCP at each of ``poses``, the level stance and the tilt steps
    (collision-free holding the carrier), or None if one is out of reach or a tilt step would move a joint
    more than ``pour_max_joint_change`` (another IK branch: the arm would swing round). Solved from the
    level stance on, each step from the last one's solution (the stance from ``q0``, the arm's
    configuration when it gets there; default: now); failing that, from the last step back, so that the
    most tilted pose, the hardest to reach, picks the arm's branch."""
    limit = ctx.param("pour_max_joint_change")
    for order in (poses, poses[::-1]):
        q, qs = ctx.q_cmd if q0 is None else q0, []
        for pose in order:
            try:
                q_next = ctx.planner.ik(pose, q, rng, collision_free=True, allowed=allowed, attached=held)
            except MotionFailure:
                break
            if qs and float(np.max(np.abs(q_next - q))) > limit:
                break
            q = q_next
            qs.append(q)
        else:
            return qs if order is poses else qs[::-1]
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

    def flat(self, ctx: Context) -> bool:
        """Is the carrier flat (a tray)? Its food slides off at the friction angle, so it is carried level,
        in a straight line; and once it tilts, the food slides inside it, so the tilt steps do not carry the
        food along: it is an obstacle like any other, which only the carrier may pass through."""
        return not is_round(ctx.scene.object_model(self.carrier))

    def segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Carry to the stance, tilt step by step, hold."""
        p = ctx.params
        n, angle, flat = p["pour_steps"], ctx.variation[POUR_KNOB.name], self.flat(ctx)
        riders = () if flat else (self.food,)
        allow = ((self.carrier, self.food),) if flat else ()
        tilt = [s.linear(name, name, orientation="slerp", gripper="close", attached=self.carrier,
                         riders=riders, allow=allow, speed=p["pour_speed"])
                if angle * (k + 1) / n <= p["pour_line_deg"]
                else s.free(name, name, gripper="close", attached=self.carrier, riders=riders, allow=allow,
                            speed=p["pour_speed"])
                for k, name in enumerate(self.names(ctx)[1:])]
        carry = s.free("carry", "pour_start", gripper="close", attached=self.carrier, riders=(self.food,),
                       speed=p["carry_speed"])
        if flat:
            carry = replace(carry, kind="linear", orientation="slerp")
        return [carry, *tilt, s.hold("pour_settle", steps=p["pour_hold_steps"], gripper="close")]

    def target(self, name: str, ctx: Context) -> Pose:
        """Runtime target ``name`` (one of :meth:`names`), from the stance planned when first asked."""
        if "pour" not in ctx.memo:
            ctx.memo["pour"] = self.plan(ctx)
        pos, quat0, axis, angle, pivot = ctx.memo["pour"]
        k = self.names(ctx).index(name)  # 0: the stance, k: after the k-th tilt step
        if k == 0:
            return Pose(pos, quat0)
        turn = rotation_about(axis, angle * k / ctx.param("pour_steps"))
        at = pos if pivot is None else pivot + turn @ (pos - pivot)
        return Pose.from_pos_mat(at, turn @ Pose(pos, quat0).rotation())

    @staticmethod
    def _carry_end(ctx: Context, stance: Pose, rng: np.random.Generator, allowed: AllowedContacts,
                   held: Attachment) -> np.ndarray | None:
        """The arm's configuration at the end of the straight, level carry to ``stance`` (None if that line
        is out of reach or collides)."""
        try:
            return ctx.planner.line(ctx.q_cmd, stance, rng, "slerp", allowed, held).q[-1]
        except MotionFailure:
            return None

    def plan(self, ctx: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray | None]:
        """The pour stance: TCP position, level orientation, tilt axis and angle, and the point the tilt
        turns about (None: the TCP; a tray: its exit edge, see the module docstring); its IK solutions become
        the segments' seeds (``ctx.q_hints``). None reachable ends the attempt (``target_fail``)."""
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
        n, rot0, limit = ctx.param("pour_steps"), tcp.rotation(), ctx.param("pour_max_joint_change")
        loose, flat = ctx.scene.loose_bodies(self.food), self.flat(ctx)
        held = Attachment(self.carrier, in_tcp.matrix(), riders=tuple(loose))
        allowed = AllowedContacts(tuple((ROOT_BODY, b) for b in loose))
        tilting = (AllowedContacts(tuple((self.carrier, b) for b in loose)),
                   Attachment(self.carrier, in_tcp.matrix())) if flat else (allowed, held)
        rng = ctx.variation.rng("pour_stance")
        offsets = [(0.0, 0.0), *((float(a), float(b)) for a, b in
                                 np.asarray(ctx.param("pour_aim_offsets")).reshape(-1, 2))]
        away = tray.pos - ctx.scene.data.xpos[ctx.scene.model.body(ROOT_BODY).id]
        facing = math.atan2(away[1], away[0]) - math.atan2(radial[1], radial[0])
        facing = math.atan2(math.sin(facing), math.cos(facing))  # turn putting the radial away from the robot
        if flat:  # the hand toward the robot: it rises over the exit edge away from it, where the arm reaches
            facing = math.atan2(math.sin(facing + math.pi), math.cos(facing + math.pi))
        yaws = (0.0, facing, facing / 2) if abs(facing) > math.radians(10.0) else (0.0,)
        yaws += tuple(math.radians(a) for a in ctx.param("pour_turns_deg"))
        betas = (0.0,) if flat else tuple(math.radians(b) for b in ctx.param("pour_axis_turns_deg"))
        grip = in_tcp.inverse().pos  # the TCP in the carrier's frame: a tray's exit is the opposite wall
        least = math.degrees(slide_tilt(ctx, self.carrier, self.food)) + ctx.param("pour_slide_margin_deg")
        first = max(ctx.variation[POUR_KNOB.name], least)
        for angle in (math.radians(min(first + d, 150.0)) for d in (0.0, 10.0, 20.0)):
            for beta, yaw in ((b, y) for b in betas for y in yaws):
                level = rotation_about(UP, yaw) @ rot0
                axis = np.cross(rotation_about(UP, yaw) @ radial, UP)  # turning about it lowers the far rim
                axis = rotation_about(UP, beta) @ axis  # … or the rim ``beta`` round from it
                spins = [rotation_about(axis, angle * k / n) for k in range(n + 1)]
                turns = [r @ level for r in spins]
                if flat:  # turned about the exit edge, which stays over the aim point
                    exit_point = np.array([-grip[0], -grip[1], model.size[2]])
                    exit_off = level @ in_tcp.pos + (level @ in_tcp.rotation()) @ exit_point
                    around = corners @ (level @ in_tcp.rotation()).T + level @ in_tcp.pos - exit_off
                    low = min(float(np.min((around @ r.T)[:, 2])) for r in spins)
                else:  # turned about the TCP, the mouth over the aim point at the final tilt
                    low = min(float(np.min((r @ in_tcp.pos + corners @ (r @ in_tcp.rotation()).T)[:, 2]))
                              for r in turns)
                    exit_off = turns[-1] @ in_tcp.pos + (turns[-1] @ in_tcp.rotation()) @ mouth
                for up, (dx, dy) in ((u, o) for u in ctx.param("pour_lifts") for o in offsets):
                    aim = tray.pos + tray.rotation() @ np.array([dx, dy, cavity.rim_z])
                    over = np.array([aim[0], aim[1], aim[2] + ctx.param("pour_clearance") + up - low])
                    pos = over - exit_off if flat else np.array([*(aim[:2] - exit_off[:2]), over[2]])
                    pivot = over if flat else None
                    poses = [Pose.from_pos_mat(pos if pivot is None else pivot + r @ (pos - pivot), t)
                             for r, t in zip(spins, turns, strict=True)]
                    arrive = (self._carry_end(ctx, poses[0], rng, allowed, held) if flat else None)
                    if flat and arrive is None:
                        continue
                    qs = tilt_chain(ctx, poses, rng, *tilting, arrive)
                    if qs is None or (arrive is not None and float(np.max(np.abs(qs[0] - arrive))) > limit):
                        continue
                    ctx.q_hints.update(zip(self.names(ctx), qs, strict=True))
                    return pos, Pose.from_pos_mat(pos, level).quat, axis, angle, pivot
        raise AttemptFailed("target_fail", f"no pour stance over the tray is reachable holding the carrier "
                            f"({len(offsets)} aim points, {len(yaws)} turns, {len(betas)} tilt axes; "
                            f"{first:.0f}°, 10° and 20° more)")
