"""Wiping a patch (of dust) off the floor of a tray with a held tool (a sponge): over the patch's first
corner, press down with a guarded move, a zig-zag of sliding guarded strokes over the patch, touch-up strokes
over what is left, lift off.

The patch (``patch``: a particle object lying on the tray, :mod:`mgdata.sim.particles`) moves with the tray;
each stroke aims at where the tray is now. Stroke rows are ``row_overlap`` of the tool's narrow width apart;
the tool keeps ``wall_clearance`` inside the tray's walls. The tool's start is turned about the vertical by
the first of 0°, 180°, ±90° that the arm reaches holding it (its IK seeds the segment's, ``ctx.q_hints``).
Dust left when the tool lifts off ends the attempt (``target_fail``, "wipe incomplete").

Segments and runtime targets: ``wipe_above``, ``wipe_press``, ``wipe_0`` … (strokes), ``wipe_up``. A
skeleton declares :data:`WIPE_KEYS` and the knob :data:`WIPE_KNOB` and plugs it in::

    wipe = Wipe("sponge", tray="dest", patch="dust")
    segs = wipe.segments(ctx)
    pose = wipe.target(name, ctx)          # for names in wipe.names(ctx)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.motion import Attachment, Pose
from mgdata.sim.assets.model import Cavity
from mgdata.skeleton import segment as s
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import UP, raised, rotation_about
from mgdata.tasks.recipe_keys import Knob, Param, RecipeKeys

WIPE_KEYS = RecipeKeys(params=(
    Param("wipe_hover", float, "m above the tray's floor the press starts", 0.0, 0.1),
    Param("press_travel", float, "m past ``wipe_hover`` the press may go (the sponge gives "
          "and the servos lag)", 0.0, 0.05),
    Param("press_force", float, "N at which the guarded press stops", 0.1, 50.0),
    Param("max_press_force", float, "N the press never exceeds", 0.1, 100.0),
    Param("stroke_force", float, "N the strokes press with at least", 0.1, 50.0),
    Param("max_stroke_force", float, "N the strokes never exceed", 0.1, 100.0),
    Param("touch_up_strokes", int, "strokes after the zig-zag, each over the remaining speck "
          "nearest the sponge (a short one towards the patch centre if none is left)", 0, 20),
    Param("row_overlap", float, "spacing of the stroke rows, fraction of the sponge's width", 0.1, 1.0),
    Param("touch_up_overshoot", float, "m a touch-up stroke carries the sponge's centre past "
          "its speck", 0.0, 0.1),
    Param("wall_clearance", float, "m the sponge keeps inside the tray's walls", 0.0, 0.1),
    Param("wipe_speed", float, "fraction of the planned speed while wiping", 0.01, 1.0),
))
"""The recipe keys a wipe reads."""
WIPE_KNOB = Knob("wipe_press_dx", "m offset of the first press along the patch", -0.02, 0.02)
"""The variation knob a wipe reads (declared by the skeleton, in its own order)."""
START_TURNS = (0.0, math.pi, math.pi / 2, -math.pi / 2)
"""Turns of the tool about the vertical tried for the wipe's start, in order."""


@dataclass(frozen=True)
class Wipe:
    """Wipe ``patch`` off ``tray``'s floor with the held ``tool`` (see the module docstring)."""

    tool: str
    tray: str
    patch: str

    def strokes(self, ctx: Context) -> int:
        """How many strokes: the zig-zag's and the touch-ups."""
        return 2 * len(self._rows(ctx)) - 1 + ctx.params["touch_up_strokes"]

    def names(self, ctx: Context) -> tuple[str, ...]:
        """Its runtime targets."""
        return ("wipe_above", *(f"wipe_{i}" for i in range(self.strokes(ctx))), "wipe_up")

    def segments(self, ctx: Context) -> list[s.MotionSegment]:
        """Over the first corner, press, strokes, lift off (the tool held all along)."""
        p, tool = ctx.params, self.tool
        on_tray = ((tool, self.tray),)
        return [
            s.free("wipe_above", "wipe_above", gripper="close", attached=tool),
            s.guarded("wipe_press", (0.0, 0.0, -1.0), until=s.force(self.tray, p["press_force"]),
                      max_force=p["max_press_force"], max_distance=p["wipe_hover"] + p["press_travel"],
                      gripper="close", attached=tool, allow=((tool, "table"),)),
            *[s.guarded(f"wipe_{i}", f"wipe_{i}", until=s.force(self.tray, p["stroke_force"]),
                        max_force=p["max_stroke_force"], press=(0.0, 0.0, -1.0), speed=p["wipe_speed"],
                        gripper="close", attached=tool, allow=on_tray)
              for i in range(self.strokes(ctx))],
            s.linear("wipe_up", "wipe_up", allow=on_tray, gripper="close", attached=tool),
        ]

    def target(self, name: str, ctx: Context) -> Pose:
        """Runtime target ``name`` (one of :meth:`names`)."""
        if name == "wipe_above":
            return self._start(ctx)
        tcp = ctx.commanded_tcp()
        if name == "wipe_up":
            self._check_clean(ctx)
            return raised(tcp, ctx.param("wipe_hover") * 2)
        i = self.names(ctx).index(name) - 1  # the stroke's number
        centre, rot, hx, hy = self._patch(ctx)  # where the tray is now
        rows = np.clip(self._rows(ctx), -hy, hy)
        if i >= 2 * len(rows) - 1:
            return self._touch_up(ctx, centre, rot)
        row = rows[(i + 1) // 2]
        x = hx if (i // 2) % 2 == 0 else -hx  # strokes 0, 1 end at +x; 2, 3 at -x; …
        point = centre + rot[:, 0] * x + rot[:, 1] * row + ctx.memo["wipe_offset"]
        return Pose(np.array([point[0], point[1], tcp.pos[2]]), tcp.quat)

    # -- geometry ----------------------------------------------------------------------------------------
    def _patch(self, ctx: Context, tool_rot: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, float, float]:
        """The patch now: centre (world, on the tray's floor), the tray's rotation, and the half extents the
        tool's centre sweeps along the tray's x and y (clamped inside the walls)."""
        tray_spec, patch_spec = ctx.task.object(self.tray), ctx.task.object(self.patch)
        tray = ctx.object_pose(self.tray)
        rot = tray.rotation()
        c, si = math.cos(tray_spec.yaw), math.sin(tray_spec.yaw)
        offset = np.asarray(patch_spec.pos) - np.asarray(tray_spec.pos)
        local = np.array([c * offset[0] + si * offset[1], -si * offset[0] + c * offset[1], offset[2]])
        geo = ctx.scene.object_model(self.patch).geometry
        room_x, room_y = self._room(ctx, rot, tool_rot)
        if room_x < 0 or room_y < 0:
            raise AttemptFailed("target_fail", "the sponge does not fit between the tray's walls")
        local[0], local[1] = np.clip(local[0], -room_x, room_x), np.clip(local[1], -room_y, room_y)
        half_x = min(float(geo["half_x"]), room_x - abs(local[0]))
        half_y = min(float(geo["half_y"]), room_y - abs(local[1]))
        local[2] = self._cavity(ctx).floor_z
        return tray.pos + rot @ local, rot, max(half_x, 0.0), max(half_y, 0.0)

    def _cavity(self, ctx: Context) -> Cavity:
        cavity = ctx.scene.object_model(self.tray).cavity
        assert cavity is not None
        return cavity

    def _room(self, ctx: Context, tray_rot: np.ndarray,
              tool_rot: np.ndarray | None = None) -> tuple[float, float]:
        """How far (m) the tool's centre may go from the tray's centre along its x and y, inside the walls."""
        cavity, wall = self._cavity(ctx), ctx.param("wall_clearance")
        sx, sy = self._extent(ctx, tray_rot, tool_rot)
        return cavity.half_x - sx - wall, cavity.half_y - sy - wall

    def _extent(self, ctx: Context, tray_rot: np.ndarray,
                tool_rot: np.ndarray | None = None) -> tuple[float, float]:
        """Half extents of the tool's footprint along the tray's x and y axes (at its current rotation, or
        ``tool_rot``)."""
        size = np.asarray(ctx.scene.object_model(self.tool).size[:2]) / 2
        rot = ctx.object_pose(self.tool).rotation() if tool_rot is None else tool_rot
        axes = tray_rot[:, :2].T @ rot[:, :2]  # tray x/y components of the tool's x/y axes
        return float(np.abs(axes[0]) @ size), float(np.abs(axes[1]) @ size)

    def _rows(self, ctx: Context) -> np.ndarray:
        """Offsets (m, along the tray's y) of the stroke rows covering the patch."""
        width = 2 * float(min(ctx.scene.object_model(self.tool).size[:2])) / 2
        span = 2 * float(ctx.scene.object_model(self.patch).geometry["half_y"])
        n = max(1, math.ceil(span / (ctx.param("row_overlap") * width)))
        half = max(0.0, span / 2 - width / 2 * ctx.param("row_overlap"))
        return np.linspace(-half, half, n) if n > 1 else np.zeros(1)

    # -- the start and the touch-ups ---------------------------------------------------------------------
    def _start(self, ctx: Context) -> Pose:
        """Over the patch's first corner, ``wipe_hover`` up, the hand turned by the first of
        :data:`START_TURNS` the arm reaches holding the tool, collision-free (IK from the current command;
        it seeds the segment's IK)."""
        tcp, tool = ctx.commanded_tcp(), ctx.object_pose(self.tool)
        rng = ctx.variation.rng("wipe_turn")
        held = Attachment(self.tool, (ctx.tcp_pose().inverse() @ tool).matrix())

        def start(yaw: float) -> tuple[Pose, np.ndarray]:
            turn = rotation_about(UP, yaw)
            centre, rot, hx, hy = self._patch(ctx, turn @ tool.rotation())
            rows = np.clip(self._rows(ctx), -hy, hy)
            corner = centre + rot[:, 0] * (-hx + ctx.variation[WIPE_KNOB.name]) + rot[:, 1] * rows[0]
            offset = turn @ (tcp.pos - tool.pos)  # TCP minus the tool's bottom centre, turned
            hover = UP * ctx.param("wipe_hover")
            return Pose.from_pos_mat(corner + offset + hover, turn @ tcp.rotation()), offset

        search = first_reachable(map(start, START_TURNS), lambda cand: ctx.planner.ik(
            cand[0], ctx.q_cmd, rng, collision_free=True, attached=held))
        search.seed(ctx, "wipe_above")
        pose, ctx.memo["wipe_offset"] = search.found_or_first
        return pose

    def _touch_up(self, ctx: Context, centre: np.ndarray, rot: np.ndarray) -> Pose:
        """A stroke that puts the tool's centre ``touch_up_overshoot`` past the remaining speck nearest to it
        (along the line to it), kept inside the walls; back towards the patch centre if none is left."""
        tcp, top = ctx.commanded_tcp(), ctx.object_pose(self.tool).pos  # the tool's bottom centre
        specks = ctx.scene.data.mocap_pos[ctx.scene.dust.mocap_ids[self.patch]]
        specks = specks[specks[:, 2] > -1.0]
        aim = centre if not len(specks) else specks[np.argmin(np.linalg.norm(specks - top, axis=1))]
        way = (aim - top) @ rot[:, :2]  # in the tray's x/y
        dist = float(np.linalg.norm(way))
        way = way / dist if dist > 1e-6 else np.array([1.0, 0.0])
        local = (top - centre) @ rot[:, :2] + way * (dist + ctx.param("touch_up_overshoot"))
        origin = (centre - ctx.object_pose(self.tray).pos) @ rot[:, :2]  # the patch centre in the tray's x/y
        room = np.array(self._room(ctx, rot))
        local = np.clip(origin + local, -room, room) - origin
        point = centre + rot[:, :2] @ local + ctx.memo["wipe_offset"]
        return Pose(np.array([point[0], point[1], tcp.pos[2]]), tcp.quat)

    def _check_clean(self, ctx: Context) -> None:
        left = ctx.scene.dust.remaining_fraction(ctx.scene.data, self.patch)
        if left > 0.0:
            raise AttemptFailed("target_fail", f"wipe incomplete: {left:.0%} of the dust is left after the "
                                "strokes")
