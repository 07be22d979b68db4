"""Dusty: wipe the dusty destination clean with a sponge, then pour the food into it from its carrier.

The paper's "five-phase wipe-then-pour routine", on a table holding a sponge, a destination tray whose floor
carries a dust patch (``dust``, lying on ``dest``: the specks move with it and only a sponge touching it
wipes them, :mod:`mgdata.sim.particles`) and a source bowl (``source``) with a food item (``food``) inside:

1. **Pick the sponge** (its DB top grasp, raised by ``sponge_grasp_raise``): pre-grasp, approach, close,
   lift above the tray's rim.
2. **Wipe**: move the sponge over the first corner of the dust patch (the hand turned 0°, 180° or ±90° about
   the vertical, the first the arm reaches), press it onto the tray's floor with a guarded move (stops at
   ``press_force`` N, never more than ``max_press_force``), then wipe in a zig-zag of sliding guarded
   strokes over the patch (``press=`` down: in contact all the way, the force regulated between
   ``stroke_force`` and ``max_stroke_force``; light enough that the tray does not slide along), rows
   ``row_overlap`` of the sponge's narrow width apart, the sponge kept ``wall_clearance`` inside the tray's
   walls, each stroke aimed at where the tray is now; then ``touch_up_strokes`` over the remaining speck
   nearest the sponge. Lift off. Dust left ends the attempt (``target_fail``, "wipe incomplete").
3. **Put the sponge back** where it was picked up, release, retreat.
4. **Grasp the source** (Layer 2's pick): a DB rim pinch whose open fingertips keep ``food_clearance`` from
   the food (:meth:`CarrierPick.clear_of_food`), on the bowl's far side (:meth:`CarrierPick.far_side`),
   round-robin over the reachable ones; lift clear of everything.
5. **Pour**: carry the bowl (joint-space, ``carry_speed``) to the pour stance, then tilt it in
   ``pour_steps`` joint-space turns about the horizontal axis through the TCP perpendicular to the bowl's
   grasp radius, its far side down (or about that axis turned ``pour_axis_turns_deg`` about the vertical:
   the bowl pours over another rim point), to ``pour_angle_deg`` (:meth:`DustySkeleton._pour_plan`: the
   hand turned about the vertical as carried, facing away from the robot, half way or by
   ``pour_turns_deg``; the mouth over the tray, the bowl's outline ``pour_clearance`` above the rim, every
   step reachable); hold while the food falls and settles (the gate: food inside the tray, tray clean,
   upright and not moved, at rest).

The order "clean before pour" is a safety constraint of the spec (``!food_in_dest W dest_clean``), so
pouring onto a dusty tray is a violation at the step the food lands, not only a failed goal.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.grasps.db import Grasp
from mgdata.motion import AllowedContacts, Attachment, MotionFailure, Pose
from mgdata.sim.assets import ObjectModel
from mgdata.sim.geometry import box_corners
from mgdata.sim.robot import FINGERTIP_REACH, GRIPPER_MAX_OPENING, ROOT_BODY
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Knob, Param, RecipeKeys, register

_PICK_PARAMS = ("open_steps", "grasp_settle_steps", "close_steps", "lift_margin", "carry_speed",
                "grasp_margin", "grasp_clearance", "reach_standoff")
_PICK_KNOBS = ("grasp_standoff", "grasp_height", "lift_height")
UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class CarrierPick(PickAndCarry):
    """Pick-and-carry of the source carrier by grasps that keep the open hand's fingertips away from the
    food riding in it (:meth:`clear_of_food`) and lie on its far side (:meth:`far_side`)."""

    food: str = "food"

    def reachable_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        return tuple(g for g in super().reachable_grasps(ctx)
                     if self.clear_of_food(ctx, g) and self.far_side(ctx, g))

    def far_side(self, ctx: Context, grasp: Grasp) -> bool:
        """Is the grasp on the carrier's far side (its radius within ``pour_side_deg`` of the direction away
        from the robot)? Tilting the far side's opposite down then turns the hand to point away from the
        robot, a pose the arm reaches past 90°; from the near side it would have to point back at itself."""
        obj = ctx.object_pose(self.obj)
        radial = (obj.matrix() @ grasp.matrix())[:2, 3] - obj.pos[:2]
        away = obj.pos[:2] - ctx.scene.data.xpos[ctx.scene.model.body(ROOT_BODY).id][:2]
        cos = radial @ away / max(np.linalg.norm(radial) * np.linalg.norm(away), 1e-9)
        return bool(cos >= math.cos(math.radians(float(ctx.param("pour_side_deg")))))

    def clear_of_food(self, ctx: Context, grasp: Grasp) -> bool:
        """Do both fingertips of the open hand at the grasp stay ``food_clearance`` clear of the food's
        bounding box (horizontally: of its enclosing circle; or above its top)?"""
        tcp = ctx.object_pose(self.obj).matrix() @ grasp.matrix()
        food = ctx.object_pose(self.food)
        size = np.asarray(ctx.scene.object_model(self.food).size)
        clear = float(ctx.param("food_clearance"))
        reach = float(np.hypot(size[0], size[1])) / 2 + clear
        top = food.pos[2] + size[2] + clear
        for side in (1.0, -1.0):
            tip = tcp[:3, 3] + tcp[:3, 2] * FINGERTIP_REACH + side * tcp[:3, 1] * GRIPPER_MAX_OPENING / 2
            if np.hypot(*(tip[:2] - food.pos[:2])) < reach and tip[2] < top:
                return False
        return True


@dataclass(frozen=True)
class SpongePick(PickAndCarry):
    """The sponge's DB grasps raised by ``sponge_grasp_raise`` along its vertical axis (the DB's top grasp
    puts a thin sponge's fingertips within the arm's clearance of the table)."""

    def reachable_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        raised = tuple(replace(g, pos=(g.pos[0], g.pos[1], g.pos[2] + self.raise_by(ctx)))
                       for g in ctx.grasps.get(self.obj, ()))
        return super().reachable_grasps(replace(ctx, grasps={**ctx.grasps, self.obj: raised}))

    @staticmethod
    def raise_by(ctx: Context) -> float:
        return float(ctx.param("sponge_grasp_raise"))


def _outline(model: ObjectModel) -> np.ndarray:
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


def _slide_tilt(ctx: Context, carrier: str = "source", food: str = "food") -> float:
    """Tilt (rad) of the carrier at which the food slides out along its lowest wall: the wall's slope below
    the horizontal, ``tilt - 90° + flare`` (the wall's angle from the carrier's axis; 0 for a box), exceeds
    the friction angle ``atan(mu)``, ``mu`` the larger sliding friction of the two objects' geoms (MuJoCo's
    default contact mixing)."""
    geo = ctx.scene.object_model(carrier).geometry
    flare = 0.0
    if "rim_radius" in geo and "bottom_radius" in geo:
        flare = math.atan2(float(geo["rim_radius"]) - float(geo["bottom_radius"]), float(geo["height"]))
    m = ctx.scene.model
    roots = {m.body(carrier).id, m.body(food).id}
    mu = max(float(m.geom_friction[g, 0]) for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] in roots)
    return math.pi / 2 - flare + math.atan(mu)


def _turn(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` (rad) about the unit ``axis``."""
    a = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


@register
class DustySkeleton(FamilySkeleton):
    """The dusty family's demonstration (see the module docstring)."""

    name = "dusty"
    recipe_keys = RecipeKeys(
        params=(*(p for p in PICK_AND_CARRY_KEYS.params if p.name in _PICK_PARAMS),
                Param("food_clearance", float, "m the open fingertips of a carrier grasp keep from the food",
                      0.0, 0.2),
                Param("pour_side_deg", float, "a carrier grasp's radius is at most this far from the "
                      "direction away from the robot", 0.0, 180.0),
                Param("sponge_grasp_raise", float, "m the sponge's DB grasp is raised along its vertical",
                      0.0, 0.05),
                Param("sponge_lift", float, "m the sponge's bottom clears the tallest object when moved",
                      0.0, 0.2),
                Param("wipe_hover", float, "m above the tray's floor the press starts", 0.0, 0.1),
                Param("press_travel", float, "m past ``wipe_hover`` the press may go (the sponge gives "
                      "and the servos lag)", 0.0, 0.05),
                Param("press_force", float, "N at which the guarded press stops", 0.1, 50.0),
                Param("max_press_force", float, "N the press never exceeds", 0.1, 100.0),
                Param("stroke_force", float, "N the strokes press with at least", 0.1, 50.0),
                Param("max_stroke_force", float, "N the strokes never exceed", 0.1, 100.0),
                Param("touch_up_strokes", int, "strokes after the zig-zag, each over the remaining speck "
                      "nearest the sponge (a short one towards the patch centre if none is left)", 0, 20),
                Param("row_overlap", float, "spacing of the stroke rows, fraction of the sponge's width",
                      0.1, 1.0),
                Param("touch_up_overshoot", float, "m a touch-up stroke carries the sponge's centre past "
                      "its speck", 0.0, 0.1),
                Param("wall_clearance", float, "m the sponge keeps inside the tray's walls", 0.0, 0.1),
                Param("wipe_speed", float, "fraction of the planned speed while wiping", 0.01, 1.0),
                Param("place_drop", float, "m above its start the sponge is released", 0.0, 0.05),
                Param("pour_steps", int, "turns the tilt is split into", 1, 50),
                Param("pour_speed", float, "fraction of the planned speed while tilting", 0.01, 1.0),
                Param("pour_line_deg", float, "tilts up to this are straight turns about the TCP; beyond, "
                      "joint-space moves (the wrist passes a singularity near 90°)", 0.0, 180.0),
                Param("pour_aim_offsets", tuple, "m (x, y pairs in the tray's frame) of the other points "
                      "the mouth may pour over if the centre's stance is out of reach", -0.2, 0.2),
                Param("pour_clearance", float, "m the tilted bowl's outline keeps above the tray's rim",
                      0.0, 0.3),
                Param("pour_max_joint_change", float, "rad a joint may move in one tilt step", 0.1, 6.3),
                Param("pour_turns_deg", tuple, "deg: further turns of the hand about the vertical the "
                      "pour stance may take (after none, the one putting the grasp away from the robot and "
                      "half of it)", -180.0, 180.0),
                Param("pour_axis_turns_deg", tuple, "deg: turns about the vertical of the tilt axis from "
                      "the one lowering the rim opposite the hand, tried in order (a round carrier pours "
                      "over any rim point alike)", -90.0, 90.0),
                Param("pour_slide_margin_deg", float, "deg the final tilt keeps past the one at which the "
                      "food slides off the carrier's lowest wall", 0.0, 60.0),
                Param("pour_hold_steps", int, "control steps holding the tilt while the food settles",
                      1, 2000)),
        variation=(*(k for k in PICK_AND_CARRY_KEYS.variation if k.name in _PICK_KNOBS),
                   Knob("pour_angle_deg", "final tilt of the carrier (deg)", 30.0, 150.0),
                   Knob("wipe_press_dx", "m offset of the first press along the patch", -0.02, 0.02)),
    )

    # -- segments ------------------------------------------------------------------------------------------
    def segments(self, ctx: Context) -> Sequence[s.MotionSegment]:
        p = ctx.params
        held = {"gripper": "close", "attached": "sponge"}
        on_tray = (("sponge", "dest"),)
        strokes = 2 * len(self._rows(ctx)) - 1
        n, angle = int(p["pour_steps"]), float(ctx.variation["pour_angle_deg"])
        tilting = {"gripper": "close", "attached": "source", "riders": ("food",),
                   "speed": float(p["pour_speed"])}
        pour = [s.linear(f"pour_{k}", f"pour_{k}", orientation="slerp", **tilting)  # type: ignore[arg-type]
                if angle * (k + 1) / n <= float(p["pour_line_deg"])
                else s.free(f"pour_{k}", f"pour_{k}", **tilting)  # type: ignore[arg-type]
                for k in range(n)]
        return [
            s.gripper("sponge_open", "open", steps=int(p["open_steps"])),
            s.free("sponge_pre", "sponge_pre"),
            s.linear("sponge_approach", "sponge_grasp", allow=(("hand", "sponge"),)),
            s.hold("sponge_settle", steps=int(p["grasp_settle_steps"])),
            s.gripper("sponge_close", "close", steps=int(p["close_steps"])),
            s.linear("sponge_lift", "sponge_lift", allow=(("sponge", "table"),), **held),  # type: ignore[arg-type]
            s.free("wipe_above", "wipe_above", **held),  # type: ignore[arg-type]
            s.guarded("wipe_press", (0.0, 0.0, -1.0), until=s.force("dest", float(p["press_force"])),
                      max_force=float(p["max_press_force"]),
                      max_distance=float(p["wipe_hover"]) + float(p["press_travel"]),
                      gripper="close", attached="sponge", allow=(("sponge", "table"),)),
            *[s.guarded(f"wipe_{i}", f"wipe_{i}", until=s.force("dest", float(p["stroke_force"])),
                        max_force=float(p["max_stroke_force"]), press=(0.0, 0.0, -1.0),
                        speed=float(p["wipe_speed"]), gripper="close", attached="sponge", allow=on_tray)
              for i in range(strokes + int(p["touch_up_strokes"]))],
            s.linear("wipe_up", "wipe_up", allow=on_tray, **held),  # type: ignore[arg-type]
            s.free("sponge_back", "sponge_back", **held),  # type: ignore[arg-type]
            s.linear("sponge_place", "sponge_place", allow=(("sponge", "table"),), **held),  # type: ignore[arg-type]
            s.gripper("sponge_release", "open", steps=int(p["open_steps"])),
            s.linear("sponge_retreat", "sponge_retreat", allow=(("hand", "sponge"),)),
            *self.carrier.pick_segments(ctx),
            s.free("carry", "pour_start", gripper="close", attached="source", riders=("food",),
                   speed=float(p["carry_speed"])),
            *pour,
            s.hold("pour_settle", steps=int(p["pour_hold_steps"]), gripper="close"),
        ]

    carrier = CarrierPick("source", riders=("food",))
    sponge = SpongePick("sponge")

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """≥ ``min_grasps`` reachable carrier grasps clear of the food, ≥ 1 reachable sponge grasp."""
        sponge = self.sponge.reachable_grasps(ctx)
        if not sponge:
            raise Infeasible("reach.sponge", f"none of the {len(ctx.grasps.get('sponge', ()))} valid grasps "
                                             "of the sponge is reachable")
        carrier = self.carrier.reachable_grasps(ctx)
        if len(carrier) < max(min_grasps, 1):
            raise Infeasible("reach.grasps", f"{len(carrier)} of the {len(ctx.grasps.get('source', ()))} "
                                             f"valid grasps of source are reachable and clear of the food "
                                             f"(needs {min_grasps})")
        return {"grasps": tuple(g.id for g in carrier), "sponge_grasps": tuple(g.id for g in sponge)}

    # -- runtime targets -----------------------------------------------------------------------------------
    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.startswith("sponge_"):
            return self._sponge_target(name, ctx)
        if name.startswith("wipe_"):
            return self._wipe_target(name, ctx)
        if name.startswith("pour_"):
            return self._pour_target(name, ctx)
        return self.carrier.resolve(name, ctx) or super().resolve(name, ctx)

    def _sponge_grasp(self, ctx: Context) -> Pose:
        """World TCP pose of this attempt's sponge grasp (round-robin over the gate's reachable ones), from
        the sponge's pose when first asked (its start pose: it is put back there)."""
        if "sponge_grasp" not in ctx.memo:
            ids = ctx.task.gate.get("sponge_grasps")
            grasps = {g.id: g for g in ctx.grasps.get("sponge", ())}
            usable = [grasps[i] for i in ids if i in grasps] if ids is not None else list(
                self.sponge.reachable_grasps(ctx))
            if not usable:
                raise AttemptFailed("no_grasp", "no reachable valid grasp of the sponge")
            grasp = usable[ctx.variation.pick(len(usable))]
            local = grasp.matrix()
            local[2, 3] += ctx.variation["grasp_height"] + SpongePick.raise_by(ctx)
            ctx.memo["sponge_grasp"] = Pose.from_matrix(ctx.object_pose("sponge").matrix() @ local)
        return ctx.memo["sponge_grasp"]

    def _sponge_target(self, name: str, ctx: Context) -> Pose:
        grasp = self._sponge_grasp(ctx)
        approach = grasp.rotation()[:, 2]
        tcp = ctx.commanded_tcp()
        if name == "sponge_pre":
            return Pose(grasp.pos - approach * ctx.variation["grasp_standoff"], grasp.quat)
        if name == "sponge_grasp":
            return grasp
        if name == "sponge_lift":
            return Pose(tcp.pos + UP * self._clearance_lift(ctx, "sponge"), tcp.quat)
        if name in ("sponge_back", "sponge_place"):
            place = grasp.pos + UP * float(ctx.param("place_drop"))
            if name == "sponge_back":
                place = np.array([place[0], place[1], max(tcp.pos[2], place[2] + 0.03)])
            return Pose(place, tcp.quat)
        if name == "sponge_retreat":
            return Pose(tcp.pos - tcp.rotation()[:, 2] * ctx.variation["grasp_standoff"], tcp.quat)
        return super().resolve(name, ctx)

    def _clearance_lift(self, ctx: Context, held: str) -> float:
        """How far up (m) the TCP goes so that the held object's lowest point is ``sponge_lift`` above the
        tallest other rigid object (at least ``lift_height``)."""
        scene = ctx.scene
        tops = [scene.object_pose(n)[0][2] + m.size[2] for n, m in scene.objects.items()
                if n != held and m.particles is None]
        low = ctx.object_pose(held).pos[2]
        return max(float(ctx.variation["lift_height"]), max(tops) + float(ctx.param("sponge_lift")) - low)

    # -- wiping --------------------------------------------------------------------------------------------
    def _patch(self, ctx: Context, sponge_rot: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, float, float]:
        """The dust patch now: centre (world, on the tray's floor), the tray's rotation, and the half
        extents the sponge's centre sweeps along the tray's x and y (clamped inside the walls)."""
        dest, dust = ctx.task.object("dest"), ctx.task.object("dust")
        tray = ctx.object_pose("dest")
        rot = tray.rotation()
        c, si = math.cos(dest.yaw), math.sin(dest.yaw)
        offset = np.asarray(dust.pos) - np.asarray(dest.pos)
        local = np.array([c * offset[0] + si * offset[1], -si * offset[0] + c * offset[1], offset[2]])
        geo = ctx.scene.object_model("dust").geometry
        cavity = ctx.scene.object_model("dest").cavity
        assert cavity is not None
        sx, sy = self._sponge_extent(ctx, rot, sponge_rot)
        room_x = cavity.half_x - sx - float(ctx.param("wall_clearance"))
        room_y = cavity.half_y - sy - float(ctx.param("wall_clearance"))
        if room_x < 0 or room_y < 0:
            raise AttemptFailed("target_fail", "the sponge does not fit between the tray's walls")
        local[0], local[1] = np.clip(local[0], -room_x, room_x), np.clip(local[1], -room_y, room_y)
        half_x = min(float(geo["half_x"]), room_x - abs(local[0]))
        half_y = min(float(geo["half_y"]), room_y - abs(local[1]))
        local[2] = cavity.floor_z
        return tray.pos + rot @ local, rot, max(half_x, 0.0), max(half_y, 0.0)

    @staticmethod
    def _sponge_extent(ctx: Context, tray_rot: np.ndarray,
                       sponge_rot: np.ndarray | None = None) -> tuple[float, float]:
        """Half extents of the sponge's footprint along the tray's x and y axes (at its current rotation, or
        ``sponge_rot``)."""
        size = np.asarray(ctx.scene.object_model("sponge").size[:2]) / 2
        rot = ctx.object_pose("sponge").rotation() if sponge_rot is None else sponge_rot
        axes = tray_rot[:, :2].T @ rot[:, :2]  # tray x/y components of the sponge's x/y axes
        return float(np.abs(axes[0]) @ size), float(np.abs(axes[1]) @ size)

    def _rows(self, ctx: Context) -> np.ndarray:
        """Offsets (m, along the tray's y) of the stroke rows covering the patch."""
        width = 2 * float(min(ctx.scene.object_model("sponge").size[:2])) / 2
        span = 2 * float(ctx.scene.object_model("dust").geometry["half_y"])
        n = max(1, math.ceil(span / (float(ctx.param("row_overlap")) * width)))
        half = max(0.0, span / 2 - width / 2 * float(ctx.param("row_overlap")))
        return np.linspace(-half, half, n) if n > 1 else np.zeros(1)

    def _wipe_target(self, name: str, ctx: Context) -> Pose:
        tcp = ctx.commanded_tcp()
        if name == "wipe_above":
            return self._wipe_start(ctx)
        if name == "wipe_up":
            self._check_clean(ctx)
            return Pose(tcp.pos + UP * float(ctx.param("wipe_hover")) * 2, tcp.quat)
        i = int(name.split("_")[1])
        centre, rot, hx, hy = self._patch(ctx)  # where the tray is now
        rows = np.clip(self._rows(ctx), -hy, hy)
        if i >= 2 * len(rows) - 1:
            return self._touch_up(ctx, centre, rot)
        row = rows[(i + 1) // 2]
        x = hx if (i // 2) % 2 == 0 else -hx  # strokes 0, 1 end at +x; 2, 3 at -x; …
        point = centre + rot[:, 0] * x + rot[:, 1] * row + ctx.memo["wipe_offset"]
        return Pose(np.array([point[0], point[1], tcp.pos[2]]), tcp.quat)

    def _wipe_start(self, ctx: Context) -> Pose:
        """Over the patch's first corner, ``wipe_hover`` up: the hand turned about the vertical by the first
        of 0°, 180°, ±90° that the arm reaches holding the sponge, collision-free (IK from the current
        command; its solution seeds the segment's IK, ``ctx.q_hints``, so the move goes where was checked)."""
        tcp, sponge = ctx.commanded_tcp(), ctx.object_pose("sponge")
        rng = ctx.variation.rng("wipe_turn")
        held = Attachment("sponge", (ctx.tcp_pose().inverse() @ sponge).matrix())
        first = None
        for yaw in (0.0, math.pi, math.pi / 2, -math.pi / 2):
            turn = _turn(UP, yaw)
            centre, rot, hx, hy = self._patch(ctx, turn @ sponge.rotation())
            rows = np.clip(self._rows(ctx), -hy, hy)
            start = centre + rot[:, 0] * (-hx + ctx.variation["wipe_press_dx"]) + rot[:, 1] * rows[0]
            offset = turn @ (tcp.pos - sponge.pos)  # TCP minus the sponge's bottom centre, turned
            hover = UP * float(ctx.param("wipe_hover"))
            pose = Pose.from_pos_mat(start + offset + hover, turn @ tcp.rotation())
            first = first or (pose, offset)
            try:
                ctx.q_hints["wipe_above"] = ctx.planner.ik(pose, ctx.q_cmd, rng, collision_free=True,
                                                           attached=held)
            except MotionFailure:
                continue
            ctx.memo["wipe_offset"] = offset
            return pose
        assert first is not None
        ctx.memo["wipe_offset"] = first[1]
        return first[0]

    def _touch_up(self, ctx: Context, centre: np.ndarray, rot: np.ndarray) -> Pose:
        """A stroke that puts the sponge's centre ``touch_up_overshoot`` past the remaining speck nearest to
        it (along the line to it), kept inside the walls; back towards the patch centre if none is left."""
        tcp, top = ctx.commanded_tcp(), ctx.object_pose("sponge").pos  # the sponge's bottom centre
        ids = ctx.scene.dust.mocap_ids["dust"]
        specks = ctx.scene.data.mocap_pos[ids]
        specks = specks[specks[:, 2] > -1.0]
        aim = centre if not len(specks) else specks[np.argmin(np.linalg.norm(specks - top, axis=1))]
        way = (aim - top) @ rot[:, :2]  # in the tray's x/y
        dist = float(np.linalg.norm(way))
        way = way / dist if dist > 1e-6 else np.array([1.0, 0.0])
        local = (top - centre) @ rot[:, :2] + way * (dist + float(ctx.param("touch_up_overshoot")))
        sx, sy = self._sponge_extent(ctx, rot)
        cavity = ctx.scene.object_model("dest").cavity
        assert cavity is not None
        tray = ctx.object_pose("dest")
        origin = (centre - tray.pos) @ rot[:, :2]  # the patch centre in the tray's x/y
        wall = float(ctx.param("wall_clearance"))
        room = np.array([cavity.half_x - sx - wall, cavity.half_y - sy - wall])
        local = np.clip(origin + local, -room, room) - origin
        point = centre + rot[:, :2] @ local + ctx.memo["wipe_offset"]
        return Pose(np.array([point[0], point[1], tcp.pos[2]]), tcp.quat)

    @staticmethod
    def _check_clean(ctx: Context) -> None:
        left = ctx.scene.dust.remaining_fraction(ctx.scene.data, "dust")
        if left > 0.0:
            raise AttemptFailed("target_fail", f"wipe incomplete: {left:.0%} of the dust is left after the "
                                "strokes")

    # -- pouring -------------------------------------------------------------------------------------------
    def _pour_target(self, name: str, ctx: Context) -> Pose:
        if "pour" not in ctx.memo:
            ctx.memo["pour"] = self._pour_plan(ctx)
        pos, quat0, axis, angle = ctx.memo["pour"]
        if name == "pour_start":
            return Pose(pos, quat0)
        k = int(name.split("_")[1]) + 1
        turn = _turn(axis, angle * k / int(ctx.param("pour_steps")))
        return Pose.from_pos_mat(pos, turn @ Pose(pos, quat0).rotation())

    @staticmethod
    def _tilt_chain(ctx: Context, pos: np.ndarray, turns: list[np.ndarray], rng: np.random.Generator,
                    allowed: AllowedContacts, held: Attachment) -> list[np.ndarray] | None:
        """Arm configurations holding the TCP at ``pos`` turned by each of ``turns`` (collision-free holding
        the bowl), or None if one is out of reach or a tilt step would move a joint more than
        ``pour_max_joint_change`` (another IK branch: the arm would swing round). Solved from the level
        stance on, each turn from the last one's solution; failing that, from the last turn back, so that
        the most tilted pose, the hardest to reach, picks the arm's branch."""
        limit = float(ctx.param("pour_max_joint_change"))
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

    def _pour_plan(self, ctx: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The pour stance: TCP position, level orientation, tilt axis and angle. The level orientation is
        the current one, else turned about the vertical so that the grasp's radius points away from the
        robot (or half way), else by each of ``pour_turns_deg``; the tilt lowers the rim opposite the hand,
        else (the tilt axis turned by ``pour_axis_turns_deg``) a rim point that far round from it: all
        turns are tried with the first axis, then with the next. The stance puts the bowl's
        mouth, at the final tilt, over a point of the tray's cavity (its centre first, then
        ``pour_aim_offsets`` along the tray's axes) with its outline (:func:`_outline`) ``pour_clearance``
        above the tray's rim at each tilt step. The tilt is the drawn angle but at least
        ``pour_slide_margin_deg`` past the food's sliding tilt (:func:`_slide_tilt`), else 10° or 20° more.
        The first stance whose every tilt step the arm reaches collision-free (:meth:`_tilt_chain`) is
        taken, and those solutions become the segments' IK seeds
        (``ctx.q_hints``: the executed tilt follows the checked branch); none ends the attempt
        (``target_fail``)."""
        tcp, bowl = ctx.commanded_tcp(), ctx.object_pose("source")
        in_tcp = tcp.inverse() @ bowl
        radial = tcp.pos - bowl.pos
        radial[2] = 0.0
        if np.linalg.norm(radial) < 1e-4:
            raise AttemptFailed("target_fail", "the carrier is held at its axis: no side to pour over")
        radial /= np.linalg.norm(radial)
        model = ctx.scene.object_model("source")
        corners, mouth = _outline(model), np.array([0.0, 0.0, model.size[2]])
        tray, cavity = ctx.object_pose("dest"), ctx.scene.object_model("dest").cavity
        assert cavity is not None
        n, rot0 = int(ctx.param("pour_steps")), tcp.rotation()
        held = Attachment("source", in_tcp.matrix(), riders=tuple(ctx.scene.loose_bodies("food")))
        allowed = AllowedContacts(tuple((ROOT_BODY, b) for b in ctx.scene.loose_bodies("food")))
        rng = ctx.variation.rng("pour_stance")
        offsets = [(0.0, 0.0), *((float(a), float(b)) for a, b in
                                 np.asarray(ctx.param("pour_aim_offsets")).reshape(-1, 2))]
        away = tray.pos - ctx.scene.data.xpos[ctx.scene.model.body(ROOT_BODY).id]
        facing = math.atan2(away[1], away[0]) - math.atan2(radial[1], radial[0])
        facing = math.atan2(math.sin(facing), math.cos(facing))  # turn putting the radial away from the robot
        yaws = (0.0, facing, facing / 2) if abs(facing) > math.radians(10.0) else (0.0,)
        yaws += tuple(math.radians(float(a)) for a in ctx.param("pour_turns_deg"))
        betas = tuple(math.radians(float(b)) for b in ctx.param("pour_axis_turns_deg"))
        least = math.degrees(_slide_tilt(ctx)) + float(ctx.param("pour_slide_margin_deg"))
        first = max(float(ctx.variation["pour_angle_deg"]), least)
        for angle in (math.radians(min(first + d, 150.0)) for d in (0.0, 10.0, 20.0)):
            for beta, yaw in ((b, y) for b in betas for y in yaws):
                level = _turn(UP, yaw) @ rot0
                axis = np.cross(_turn(UP, yaw) @ radial, UP)  # turning about it lowers the opposite rim
                axis = _turn(UP, beta) @ axis  # … or the rim ``beta`` round from it
                turns = [_turn(axis, angle * k / n) @ level for k in range(n + 1)]
                low = min(float(np.min((r @ in_tcp.pos + corners @ (r @ in_tcp.rotation()).T)[:, 2]))
                          for r in turns)
                mouth_off = turns[-1] @ in_tcp.pos + (turns[-1] @ in_tcp.rotation()) @ mouth
                for dx, dy in offsets:
                    aim = tray.pos + tray.rotation() @ np.array([dx, dy, cavity.rim_z])
                    pos = np.array([aim[0] - mouth_off[0], aim[1] - mouth_off[1],
                                    aim[2] + float(ctx.param("pour_clearance")) - low])
                    qs = self._tilt_chain(ctx, pos, turns, rng, allowed, held)
                    if qs is None:
                        continue
                    names = ("pour_start", *(f"pour_{k}" for k in range(n)))
                    ctx.q_hints.update(zip(names, qs, strict=True))
                    return pos, Pose.from_pos_mat(pos, level).quat, axis, angle
        raise AttemptFailed("target_fail", f"no pour stance over the tray is reachable holding the bowl "
                            f"({len(offsets)} aim points, {len(yaws)} turns, {len(betas)} tilt axes; "
                            f"{first:.0f}°, 10° and 20° more)")
