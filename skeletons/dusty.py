"""Dusty: wipe the dusty destination clean with a sponge, then pour the food into it from its carrier.

The paper's "five-phase wipe-then-pour routine", on a table holding a sponge, a destination tray whose floor
carries a dust patch (``dust``, lying on ``dest``: the specks move with it and only a sponge touching it
wipes them, :mod:`mgdata.sim.particles`) and a source (``source``: a bowl; a tray in a recipe that draws
one, docs/families.md) with a food item (``food``) inside:

1. **Pick the sponge** (its DB top grasp, raised by ``sponge_grasp_raise``): pre-grasp, approach, close,
   lift above the tray's rim.
2. **Wipe** (Layer 2's :class:`~mgdata.skeleton.wipe.Wipe`): over the first corner of the dust patch (the
   hand turned 0°, 180° or ±90° about the vertical, the first the arm reaches), press the sponge onto the
   tray's floor with a guarded move (``press_force`` N, never more than ``max_press_force``), then a zig-zag
   of sliding guarded strokes over the patch (force regulated between ``stroke_force`` and
   ``max_stroke_force``, light enough that the tray does not slide along) and ``touch_up_strokes`` over the
   remaining speck nearest the sponge. Lift off. Dust left ends the attempt (``target_fail``).
3. **Put the sponge back** where it was picked up: lower it slowly (``sponge_place_speed``) until its lowest
   point is ``place_drop`` above where it was (it may have slipped in the fingers while wiping), hold it
   there ``sponge_settle_steps`` while the arm catches up, release, retreat. Released at once, where the
   arm had stopped short, it fell 7 mm and sank 2.4 mm into the table; lowered at full speed, it was driven
   into the table and tipped on an edge.
4. **Grasp the source** (Layer 2's :class:`~mgdata.skeleton.carrier.CarrierPick`): a DB rim pinch from
   straight above (``carrier_tilt_max_deg``: the pour is tuned for it, not for the pinch along a bowl's
   wall) whose open fingertips keep ``food_clearance`` from the food (:meth:`CarrierPick.clear_of_food`), on
   a bowl's far side or a tray's near side in the roll the tilt needs (:meth:`CarrierPick.pouring_side`),
   round-robin over the reachable ones; lift clear of everything.
5. **Pour** (Layer 2's :class:`~mgdata.skeleton.pour.Pour`): carry the source (``carry_speed``; a bowl in
   joint space, a tray level in a straight line) to the pour stance, then tilt it in ``pour_steps`` turns
   about a horizontal axis, its far side down, to ``pour_angle_deg`` (at least ``pour_slide_margin_deg``
   past where the food slides out; its outline ``pour_clearance`` above the rim, every step reachable): a
   bowl about the TCP, its mouth over the tray; a tray about its far wall's top edge, held over the tray
   (the food slides down the tray and over that edge, the wall climbed only past 90° + the friction angle).
   Hold while the food falls and settles (the gate: food inside the tray, tray clean, upright and not
   moved, at rest).

Phases (a restart from a mid-task state, :mod:`mgdata.skeleton.phase`): ``wipe`` (steps 1-3, done once
``dest_clean`` holds) and ``pour`` (steps 4-5).

The order "clean before pour" is a safety constraint of the spec (``!food_in_dest W dest_clean``), so
pouring onto a dusty tray is a violation at the step the food lands, not only a failed goal.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from mgdata.grasps.db import Grasp
from mgdata.motion import Pose
from mgdata.sim.geometry import LowestPoint
from mgdata.skeleton import segment as s
from mgdata.skeleton.carrier import CARRIER_KEYS, CarrierPick
from mgdata.skeleton.context import Context
from mgdata.skeleton.grasp_choice import choose_grasp
from mgdata.skeleton.phase import Phase
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.pick_place import PickPlace
from mgdata.skeleton.poses import backed_off, raised
from mgdata.skeleton.pour import POUR_KEYS, POUR_KNOB, Pour
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Param, RecipeKeys, register
from mgdata.skeleton.wipe import WIPE_KEYS, WIPE_KNOB, Wipe

_PICK_PARAMS = ("open_steps", "grasp_settle_steps", "close_steps", "lift_margin", "carry_speed",
                "grasp_margin", "grasp_clearance", "reach_standoff")
_PICK_KNOBS = ("grasp_standoff", "grasp_height", "lift_height")
SPONGE = PickPlace("sponge", tag="sponge_", renamed={"pre_grasp": "pre", "grasp_settle": "settle"})
"""The sponge's pick and put-back segments (``sponge_open``, ``sponge_pre`` … ``sponge_retreat``)."""


@dataclass(frozen=True)
class SpongePick(PickAndCarry):
    """The sponge's DB grasps raised by ``sponge_grasp_raise`` along its vertical axis (the DB's top grasp
    puts a thin sponge's fingertips within the arm's clearance of the table)."""

    def reachable_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        up = ctx.param("sponge_grasp_raise")
        raised_grasps = tuple(replace(g, pos=(g.pos[0], g.pos[1], g.pos[2] + up))
                              for g in ctx.grasps.get(self.obj, ()))
        return super().reachable_grasps(replace(ctx, grasps={**ctx.grasps, self.obj: raised_grasps}))


@register
class DustySkeleton(FamilySkeleton):
    """The dusty family's demonstration (see the module docstring)."""

    name = "dusty"
    recipe_keys = RecipeKeys(params=(
        *(p for p in PICK_AND_CARRY_KEYS.params if p.name in _PICK_PARAMS),
        *CARRIER_KEYS.params,
        Param("sponge_grasp_raise", float, "m the sponge's DB grasp is raised along its vertical", 0.0, 0.05),
        Param("sponge_lift", float, "m the sponge's bottom clears the tallest object when moved", 0.0, 0.2),
    )) + WIPE_KEYS + RecipeKeys(params=(
        Param("place_drop", float, "m above where it was the sponge's lowest point is lowered to",
              0.0, 0.05),
        Param("sponge_place_speed", float, "fraction of the planned speed lowering the sponge to "
              "``place_drop`` (at full speed the arm overshot it by 3 mm)", 0.01, 1.0),
        Param("sponge_settle_steps", int, "control steps the lowered sponge is held before it is released "
              "(the arm catching up)", 0, 100),
    )) + POUR_KEYS + RecipeKeys(variation=(
        *(k for k in PICK_AND_CARRY_KEYS.variation if k.name in _PICK_KNOBS), POUR_KNOB, WIPE_KNOB))

    carrier = CarrierPick("source", riders=("food",))
    sponge = SpongePick("sponge")
    wipe = Wipe("sponge", tray="dest", patch="dust")
    pour = Pour("source", food="food", dest="dest")

    # -- phases: wipe (pick the sponge, wipe, put it back) -> pour (grasp the source, pour) ---------------
    def phases(self, ctx: Context) -> Sequence[Phase]:
        wipe = (*self._pick_sponge(ctx), *self.wipe.segments(ctx), *self._put_sponge_back(ctx))
        return [Phase("wipe", wipe, done="dest_clean"),
                Phase("pour", (*self.carrier.pick_segments(ctx), *self.pour.segments(ctx)))]

    @staticmethod
    def _pick_sponge(ctx: Context) -> list[s.MotionSegment]:
        """Open, pre-grasp, approach, settle, close, lift above everything (``sponge_lift``)."""
        return SPONGE.pick(ctx.params)

    @staticmethod
    def _put_sponge_back(ctx: Context) -> list[s.MotionSegment]:
        """Carry the sponge over where it was picked up, lower it to ``place_drop`` above that, hold, release,
        retreat."""
        p = ctx.params
        lower, release, retreat = SPONGE.place("sponge_place", retreat_steps=p["open_steps"])
        lower = replace(lower, speed=p["sponge_place_speed"])
        settle = s.hold("sponge_settle", steps=p["sponge_settle_steps"], gripper="close")
        return [s.free("sponge_back", "sponge_back", gripper="close", attached="sponge"),
                lower, settle, release, retreat]

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
        if name in self.wipe.names(ctx):
            return self.wipe.target(name, ctx)
        if name in self.pour.names(ctx):
            return self.pour.target(name, ctx)
        return self.carrier.resolve(name, ctx) or super().resolve(name, ctx)

    def _sponge_grasp(self, ctx: Context) -> Pose:
        """World TCP pose of this attempt's sponge grasp (round-robin over the gate's reachable ones), from
        the sponge's pose when first asked (its start pose: it is put back there)."""
        if "sponge_grasp" not in ctx.memo:
            grasp = choose_grasp(ctx, "sponge", "sponge_grasps", lambda: self.sponge.reachable_grasps(ctx),
                                 none="no reachable valid grasp of the sponge")
            local = grasp.matrix()
            local[2, 3] += ctx.variation["grasp_height"] + ctx.param("sponge_grasp_raise")
            ctx.memo["sponge_grasp"] = Pose.from_matrix(ctx.object_pose("sponge").matrix() @ local)
            ctx.memo["sponge_low"] = self._sponge_low(ctx)
        return ctx.memo["sponge_grasp"]

    @staticmethod
    def _sponge_low(ctx: Context) -> float:
        """Height (m) of the sponge's lowest point now."""
        scene = ctx.scene
        return LowestPoint(scene.model, scene.object_geom_ids("sponge"))(scene.data)

    def _sponge_target(self, name: str, ctx: Context) -> Pose:
        grasp, tcp = self._sponge_grasp(ctx), ctx.commanded_tcp()
        if name == SPONGE.name("pre_grasp"):
            return backed_off(grasp, ctx.variation["grasp_standoff"])
        if name == SPONGE.name("grasp"):
            return grasp
        if name == SPONGE.name("lift"):
            return raised(tcp, self._clearance_lift(ctx, "sponge"))
        if name in ("sponge_back", "sponge_place"):
            place = raised(grasp, ctx.param("place_drop")).pos
            if name == "sponge_back":
                place = np.array([place[0], place[1], max(tcp.pos[2], place[2] + 0.03)])
            else:  # its lowest point place_drop above where it started: it may have slipped in the fingers
                low = ctx.memo["sponge_low"] + ctx.param("place_drop")
                place = np.array([place[0], place[1], tcp.pos[2] + low - self._sponge_low(ctx)])
            return Pose(place, tcp.quat)
        if name == SPONGE.name("retreat"):
            return backed_off(tcp, ctx.variation["grasp_standoff"])
        return super().resolve(name, ctx)

    @staticmethod
    def _clearance_lift(ctx: Context, held: str) -> float:
        """How far up (m) the TCP goes so that the held object's lowest point is ``sponge_lift`` above the
        tallest other rigid object (at least ``lift_height``)."""
        scene = ctx.scene
        tops = [scene.object_pose(n)[0][2] + m.size[2] for n, m in scene.objects.items()
                if n != held and m.particles is None]
        low = ctx.object_pose(held).pos[2]
        return max(ctx.variation["lift_height"], max(tops) + ctx.param("sponge_lift") - low)
