"""Picking the carrier a pour starts from (a bowl or a tray with food inside): pick-and-carry restricted to
the grasps the pour can use.

A carrier grasp (:class:`CarrierPick`) approaches within ``carrier_tilt_max_deg`` of straight down (the pour
is tuned for the vertical pinch), keeps the open hand's fingertips ``food_clearance`` from the food riding in
it (:meth:`CarrierPick.clear_of_food`) and lies on the side the carrier pours from
(:meth:`CarrierPick.pouring_side`, within ``pour_side_deg``; :mod:`mgdata.skeleton.pour`). A skeleton
declares :data:`CARRIER_KEYS` beside its pick's keys::

    carrier = CarrierPick("source", riders=("food",))
    segs = [*carrier.pick_segments(ctx), *pour.segments(ctx)]
    grasps = carrier.reachable_grasps(ctx)           # the initial-state gate's check
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mgdata.grasps.db import Grasp
from mgdata.sim.robot import FINGER_DEPTH, FINGER_HALF_WIDTH, FINGERTIP_REACH, GRIPPER_MAX_OPENING, ROOT_BODY
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PickAndCarry
from mgdata.skeleton.poses import UP
from mgdata.skeleton.pour import is_round
from mgdata.tasks.recipe_keys import Param, RecipeKeys

CARRIER_KEYS = RecipeKeys(params=(
    Param("food_clearance", float, "m the open fingertips of a carrier grasp keep from the food",
          0.0, 0.2),
    Param("pour_side_deg", float, "deg a carrier grasp's radius is at most from the direction away from "
          "the robot (a bowl's; a tray's from the direction towards it)", 0.0, 180.0),
    Param("carrier_tilt_max_deg", float, "deg a carrier grasp's approach leans from straight down at "
          "most", 0.0, 90.0),
))
"""The recipe ``[params]`` a carrier pick reads besides its pick's."""


@dataclass(frozen=True)
class CarrierPick(PickAndCarry):
    """Pick-and-carry of the source carrier by grasps that keep the open hand's fingertips away from the
    food riding in it (:meth:`clear_of_food`) and lie on its pouring side (:meth:`pouring_side`)."""

    food: str = "food"

    def reachable_grasps(self, ctx: Context) -> tuple[Grasp, ...]:
        vertical = tuple(g for g in ctx.grasps.get(self.obj, ()) if self.vertical(ctx, g))
        ctx = replace(ctx, grasps={**ctx.grasps, self.obj: vertical})
        return tuple(g for g in super().reachable_grasps(ctx)
                     if self.clear_of_food(ctx, g) and self.pouring_side(ctx, g))

    def vertical(self, ctx: Context, grasp: Grasp) -> bool:
        """Does the grasp approach within ``carrier_tilt_max_deg`` of straight down (in the carrier's
        frame)? The pour is tuned for the vertical pinch, not for a bowl's pinch along its sloping wall."""
        down = -float(grasp.matrix()[2, 2])
        return down >= math.cos(math.radians(ctx.param("carrier_tilt_max_deg")))

    def pouring_side(self, ctx: Context, grasp: Grasp) -> bool:
        """Does the grasp hold the carrier from the side it pours from: a bowl's far side (the grasp's radius
        within ``pour_side_deg`` of the direction away from the robot), a tray's near side, turned by the
        hand's roll about its own +x axis? Tilting a bowl's opposite rim down turns the hand to point away
        from the robot, a pose the arm reaches past 90°; from the near side it would have to point back at
        itself. A tray turns about its far wall's edge with the hand toward the robot
        (:class:`~mgdata.skeleton.pour.Pour`): pinched on its far wall, the stance needs the hand turned
        round, which the wrist's range gives only on a flipped shoulder where the tilt cannot go on; and of
        the near pinch's two rolls, the arm follows the tilt only with the one turning about the hand's +x
        (the other's tilt steps lose their IK or jump a joint at every stance: docs/families.md)."""
        obj = ctx.object_pose(self.obj)
        held = obj.matrix() @ grasp.matrix()
        radial = held[:2, 3] - obj.pos[:2]
        away = obj.pos[:2] - ctx.scene.data.xpos[ctx.scene.model.body(ROOT_BODY).id][:2]
        cos = radial @ away / max(np.linalg.norm(radial) * np.linalg.norm(away), 1e-9)
        side = math.cos(math.radians(ctx.param("pour_side_deg")))
        if is_round(ctx.scene.object_model(self.obj)):
            return bool(cos >= side)
        tilt_axis = np.cross([*radial, 0.0], UP)  # as the pour's: turning about it lowers the far wall
        return bool(-cos >= side and tilt_axis @ held[:3, 0] > 0.0)

    def clear_of_food(self, ctx: Context, grasp: Grasp) -> bool:
        """Do both fingertips of the open hand at the grasp stay ``food_clearance`` clear of the food's
        bounding box (horizontally: of its enclosing circle; or above its top)? A fingertip is the finger's
        footprint near its tip, ``FINGER_HALF_WIDTH`` either side of the closing plane and ``FINGER_DEPTH``
        back from its pad: the back of the finger inside a bowl is what comes over the food."""
        tcp = ctx.object_pose(self.obj).matrix() @ grasp.matrix()
        food = ctx.object_pose(self.food)
        size = np.asarray(ctx.scene.object_model(self.food).size)
        clear = ctx.param("food_clearance")
        reach = float(np.hypot(size[0], size[1])) / 2 + clear
        if (tcp[:3, 3] + tcp[:3, 2] * FINGERTIP_REACH)[2] >= food.pos[2] + size[2] + clear:
            return True  # the fingertips stay above the food
        across, out, _ = tcp[:3, :3].T @ (food.pos - tcp[:3, 3])  # the food's centre in the hand's frame
        pad = GRIPPER_MAX_OPENING / 2
        for side in (1.0, -1.0):
            behind = max(pad - side * out, side * out - pad - FINGER_DEPTH, 0.0)
            if math.hypot(max(abs(across) - FINGER_HALF_WIDTH, 0.0), behind) < reach:
                return False
        return True
