"""Lid: put the loose lid (or cap) on the container, then carry the capped container into the goal sphere.

The motion, as the paper describes it:

1. **Cap the container** (phase ``cap``, done once ``lid_seated`` holds). Grasp the lid top-down by its knob
   (the cap: by its body), round-robin over its reachable valid grasps, aimed where the arm comes to rest at
   the grasp (:mod:`mgdata.grasps.rest`: it sags 5-13 mm below a plain command, and a far cap was gripped by
   its plug, a fingertip then stopping the seat on the rim 6 mm too high); lift it until its plug clears the
   rim by the draw's ``lid_hover``; carry it (free) to where the arm rests with its axis on the container's
   and level; let the arm settle; then lower it with a guarded segment aimed ``seat_overshoot`` below the
   seat (its rest commands cancel the servos' sag, so the lid arrives on the axis) that stops once the
   container pushes back on the held lid with ``seat_force`` newtons (never more than ``seat_max_force``);
   release, back off straight up and return to the start pose (the container's grasp is then planned from
   where the gate checked it). The lid's tapered plug guides it into the mouth; nothing attaches it: it
   stays by its own weight.
2. **Carry the container** (phase ``carry``; Layer 2's pick-and-carry, the food and the lid riding on it):
   side-grasp it, lift it, carry it over the goal, lower it into the goal sphere and hold it there.

Targets for the lid are computed from the live state when each segment starts: the held lid's pose relative
to the measured TCP times the pose the lid should take over the container (``seat_height`` of the container
model). Numbers come from ``recipes/lid.toml``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.grasps.rest import resting_target
from mgdata.motion import Pose
from mgdata.sim.geometry import LowestPoint
from mgdata.skeleton import segment as s
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.grasp_choice import choose_grasp
from mgdata.skeleton.phase import Phase
from mgdata.skeleton.pick_and_carry import PICK_AND_CARRY_KEYS, PickAndCarry
from mgdata.skeleton.pick_place import PickPlace
from mgdata.skeleton.poses import about_z, backed_off, held_object, raised, yaw_of
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, Knob, Param, RecipeKeys, register

LID, CONTAINER = "lid", "container"
LID_PICK = PickPlace(LID, tag="lid_", renamed={"pre_grasp": "pre"})
"""The lid's pick: ``lid_open``, ``lid_pre``, ``lid_approach``, ``lid_grasp_settle``, ``lid_close``,
``lid_lift``."""


@register
class LidSkeleton(FamilySkeleton):
    """The lid family's demonstration (see the module docstring)."""

    name = "lid"
    recipe_keys = PICK_AND_CARRY_KEYS + RecipeKeys(
        params=(
            Param("seat_overshoot", float, "m below the seat the guarded lowering aims (it stops on contact)",
                  0.0, 0.02),
            Param("seat_force", float, "N the container pushes back on the held lid when it is seated",
                  0.1, 30.0),
            Param("seat_max_force", float, "N the guarded lowering never exceeds", 0.1, 50.0),
            Param("seat_speed", float, "fraction of the [linear] speed cap for the guarded lowering",
                  0.01, 1.0),
            Param("release_steps", int, "control steps opening the gripper over the seated lid", 1, 200),
        ),
        variation=(
            Knob("lid_hover", "m the lid's plug clears the rim while carried over the container", 0.0, 0.2),
        ),
    )
    carry = PickAndCarry(CONTAINER, riders=("food", LID))
    lid = PickAndCarry(LID)

    def phases(self, ctx: Context) -> Sequence[Phase]:
        return [Phase("cap", tuple(self._cap(ctx)), done="lid_seated"),
                Phase("carry", tuple(self.carry.segments(ctx)))]

    def _cap(self, ctx: Context) -> list[s.MotionSegment]:
        """Pick the lid, carry it over the container, seat it with a guarded move, let go, go home."""
        p = ctx.params
        ctx.memo["lid_grasp"] = choose_grasp(ctx, LID, "lid_grasps", lambda: self.lid.reachable_grasps(ctx),
                                             none="no valid grasp of the lid is reachable")
        ctx.memo["lid_home"] = ctx.commanded_tcp()
        return [
            *LID_PICK.pick(p),
            s.free("lid_carry", "lid_above", speed=p["carry_speed"], gripper="close", attached=LID),
            s.hold("lid_steady", steps=p["grasp_settle_steps"], gripper="close"),
            s.guarded("lid_seat", "lid_seated", until=s.force(CONTAINER, p["seat_force"]),
                      max_force=p["seat_max_force"], speed=p["seat_speed"], gripper="close", attached=LID),
            s.gripper("lid_release", "open", steps=p["release_steps"]),
            s.linear("lid_retreat", "lid_retreat", allow=(("hand", LID),)),
            s.free("lid_home", "lid_home", riders=(LID,)),
        ]

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """The container's pick-and-carry check, plus: a reachable lid grasp from which the arm also reaches
        the pose over the container. Returns ``{"grasps": container ids, "lid_grasps": lid ids}``."""
        facts = self.carry.feasibility(ctx, min_grasps)
        lid_grasps = self.lid.reachable_grasps(ctx)
        if not lid_grasps:
            n = len(ctx.grasps.get(LID, ()))
            raise Infeasible("reach.lid", f"none of the {n} valid grasps of the lid is reachable")
        tcp_t_lid = Pose.from_matrix(np.linalg.inv(lid_grasps[0].matrix()))
        if self._over_container(ctx, tcp_t_lid, 0.05) is None:
            raise Infeasible("reach.seat", "the arm cannot hold the lid over the container")
        return {**facts, "lid_grasps": tuple(g.id for g in lid_grasps)}

    # -- runtime targets ---------------------------------------------------------------------------------
    def resolve(self, name: str, ctx: Context) -> Pose:
        if name.startswith("lid_"):
            return self._lid_target(name, ctx)
        return self.carry.resolve(name, ctx) or super().resolve(name, ctx)

    def _lid_target(self, name: str, ctx: Context) -> Pose:
        if name in ("lid_pre", "lid_grasp"):  # aimed where the arm comes to rest (it sags 5-13 mm)
            grasp = Pose.from_matrix(ctx.object_pose(LID).matrix() @ ctx.memo["lid_grasp"].matrix())
            rested = resting_target(ctx.planner, ctx.scene.model, grasp, (ctx.q_cmd,),
                                    ctx.variation.rng("rest/lid_grasp"))
            if name == "lid_grasp":
                return rested
            rng, standoff = ctx.variation.rng("lid_pre"), ctx.variation["grasp_standoff"]
            search = first_reachable((backed_off(rested, standoff), backed_off(grasp, standoff)),
                                     lambda pose: ctx.planner.ik(pose, ctx.q_cmd, rng, collision_free=True))
            search.seed(ctx, name)  # in line with the rest pose, else (out of reach) with the grasp's
            return search.found_or_first
        if name == "lid_home":
            return ctx.memo["lid_home"]
        tcp = ctx.commanded_tcp()
        if name == "lid_lift":
            low = LowestPoint(ctx.scene.model, ctx.scene.object_geom_ids(LID))(ctx.scene.data)
            cont = ctx.object_pose(CONTAINER)
            rim = cont.pos[2] + float(ctx.scene.object_model(CONTAINER).size[2])
            return raised(tcp, max(ctx.variation["lift_height"], rim + ctx.variation["lid_hover"] - low))
        if name == "lid_retreat":
            return backed_off(tcp, ctx.variation["grasp_standoff"])
        if name in ("lid_above", "lid_seated"):
            tcp_t_lid = held_object(ctx, LID).in_tcp
            plug = float(ctx.scene.object_model(LID).geometry["plug_depth"])
            if name == "lid_seated":  # straight down from where the lid is now: keep the carry's turn
                yaw = yaw_of(ctx.object_pose(LID))
                return self._lid_over(ctx, tcp_t_lid, -ctx.param("seat_overshoot"), yaw)
            up = ctx.variation["lid_hover"] + plug
            target = self._over_container(ctx, tcp_t_lid, up)
            if target is None:
                raise AttemptFailed("target_fail", "no turn of the held lid over the container is reachable")
            # where the arm comes to rest with it: the guarded lowering starts from there towards the seat
            return resting_target(ctx.planner, ctx.scene.model, target, (ctx.q_cmd,),
                                  ctx.variation.rng("rest/lid_above"))
        return super().resolve(name, ctx)

    def _over_container(self, ctx: Context, tcp_t_lid: Pose, up: float) -> Pose | None:
        """TCP pose holding the lid level on the container's axis, ``up`` m above its seat, turned about the
        vertical by the first of ``carry_yaws_deg`` the arm reaches (a round lid), or as the container is
        turned, the nearer of the two ways round first (a rectangular lid: a lunchbox's)."""
        rng, base = ctx.variation.rng("lid_yaw"), yaw_of(ctx.object_pose(LID))
        if "half_extents" in ctx.scene.object_model(LID).geometry:  # a rectangular lid: the container's turn
            cont = yaw_of(ctx.object_pose(CONTAINER))
            yaws = sorted((cont, cont + math.pi), key=lambda y: abs(math.remainder(y - base, 2 * math.pi)))
        else:
            yaws = [base + math.radians(turn) for turn in ctx.param("carry_yaws_deg")]
        turns = (self._lid_over(ctx, tcp_t_lid, up, yaw) for yaw in yaws)
        return first_reachable(turns, lambda target: ctx.planner.ik(target, ctx.q_cmd, rng)).found

    @staticmethod
    def _lid_over(ctx: Context, tcp_t_lid: Pose, up: float, yaw: float) -> Pose:
        cont = ctx.object_pose(CONTAINER)
        seat = float(ctx.scene.object_model(CONTAINER).geometry["seat_height"])
        pos = cont.pos + cont.rotation()[:, 2] * (seat + up)
        return Pose(pos, about_z(yaw)) @ tcp_t_lid.inverse()
