"""Driving an articulation by its handle: a sliding joint (a drawer) moved by a grasp on its handle
(:class:`Slide`, :class:`Drawer`: what it sweeps, what is in its way), and the segments, targets and arm path
that do it (:class:`HandleDrive`).

The slide runs along the object's own +x; its position is the joint's qpos (m, 0 closed). Handle grasps
come from the grasp DB in the moving link's frame (:meth:`~mgdata.grasps.db.Grasp.world_matrix`).

Example::

    drawer = Slide("cabinet")
    pre = backed_off(drawer.handle(ctx, grasp), 0.08)
    pulled = drawer.handle_at(ctx, grasp, 0.2)       # the handle grasp with the drawer 20 cm open
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mgdata.motion import AllowedContacts, MotionFailure, Pose
from mgdata.skeleton import segment as s
from mgdata.skeleton.opening import Opening
from mgdata.skeleton.poses import backed_off
from mgdata.skeleton.reach import arm_path
from mgdata.tasks.placer import footprint_radius

if TYPE_CHECKING:
    from mgdata.grasps.db import Grasp
    from mgdata.skeleton.context import Context


@dataclass(frozen=True)
class Slide:
    """The sliding articulation of task object ``obj``."""

    obj: str

    def q(self, ctx: Context) -> float:
        """The slide's position now (m)."""
        return float(ctx.scene.data.qpos[ctx.scene.articulation_qpos_adr(self.obj)])

    def axis(self, ctx: Context) -> np.ndarray:
        """The world direction the slide opens along."""
        return ctx.object_pose(self.obj).rotation()[:, 0]

    def handle(self, ctx: Context, grasp: Grasp) -> Pose:
        """The TCP pose of handle grasp ``grasp`` now."""
        return Pose.from_matrix(grasp.world_matrix(ctx.scene.model, ctx.scene.data, self.obj))

    def handle_moved(self, ctx: Context, grasp: Grasp, by: float) -> Pose:
        """The TCP pose of ``grasp`` with the slide moved ``by`` m from where it is now."""
        pose = self.handle(ctx, grasp)
        return Pose(pose.pos + self.axis(ctx) * by, pose.quat)

    def handle_at(self, ctx: Context, grasp: Grasp, q: float) -> Pose:
        """The TCP pose of ``grasp`` with the slide at position ``q`` (m)."""
        return self.handle_moved(ctx, grasp, q - self.q(ctx))

    def drivable_grasps(self, ctx: Context, grasps: Sequence[Grasp], *, standoff: float, stroke: float,
                        margin: float, rng: np.random.Generator, allowed: AllowedContacts,
                        touch: AllowedContacts) -> tuple[Grasp, ...]:
        """The handle grasps (with the slide where it is now) that drive it ``stroke`` m open: a
        collision-free pre-grasp ``standoff`` back (the pairs in ``allowed`` may touch) ``margin`` rad from
        the joint limits, and straight approach and pull lines that solve (the pairs in ``touch`` may
        touch), every configuration ``margin`` from the joint limits."""
        planner = ctx.planner
        axis = self.axis(ctx)
        planner.sync(ctx.scene.data)
        out = []
        for grasp in grasps:
            pose = self.handle(ctx, grasp)
            try:  # a pre-grasp solution near a joint limit is no reason to drop the grasp: take another
                q_pre = planner.ik(backed_off(pose, standoff), ctx.q_cmd, rng, collision_free=True,
                                   allowed=allowed, limit_margin=margin)
                approach = planner.line(q_pre, pose, rng, allowed=touch)
                pull = planner.line(approach.q[-1], Pose(pose.pos + axis * stroke, pose.quat), rng,
                                    allowed=touch)
            except MotionFailure:
                continue
            qs = np.vstack([q_pre[None], approach.q, pull.q])
            room = float(np.min(np.minimum(qs - planner.lower, planner.upper - qs)))
            if room >= margin:
                out.append(grasp)
        return tuple(out)



@dataclass(frozen=True)
class Drawer(Slide):
    """A drawer: a :class:`Slide` whose object's ``geometry`` has the drawer asset's keys (closed, object
    frame: ``front_x``, ``half_extents``, ``handle_pos``, ``handle_radius``, ``drawer_inner``,
    ``drawer_floor_z``, ``travel``; :mod:`mgdata.sim.assets.cabinet`)."""

    def travel(self, ctx: Context) -> float:
        """How far (m) the drawer opens."""
        return ctx.scene.object_model(self.obj).geometry["travel"]

    def sweep_gap(self, ctx: Context, xy: np.ndarray, stroke: float) -> float:
        """Distance (m) from the world point ``xy`` to the xy box the drawer and its handle sweep when opened
        ``stroke`` m (0 inside it)."""
        frame, geo = ctx.object_pose(self.obj), ctx.scene.object_model(self.obj).geometry
        local = frame.rotation()[:2, :2].T @ (np.asarray(xy) - frame.pos[:2])
        hy = geo["half_extents"][1]
        lo = np.array([geo["front_x"], -hy])
        hi = np.array([geo["handle_pos"][0] + geo["handle_radius"] + stroke, hy])
        return float(np.hypot(*np.maximum(np.maximum(lo - local, local - hi), 0.0)))

    def in_the_way(self, ctx: Context, names: Sequence[str], *, stroke: float, margin: float) -> list[str]:
        """Those of the task objects ``names`` (in their order) whose footprint comes within ``margin`` m of
        what the drawer sweeps when opened ``stroke`` m (:meth:`sweep_gap`)."""
        return [n for n in names if self.sweep_gap(ctx, ctx.object_pose(n).pos[:2], stroke)
                < footprint_radius(ctx.task.object(n).model) + margin]

    def opening(self, ctx: Context) -> Opening:
        """The part of the drawer's interior outside the carcass now (as it is open)."""
        geo, q = ctx.scene.object_model(self.obj).geometry, self.q(ctx)
        hxi, hyi, depth = geo["drawer_inner"]
        floor = geo["drawer_floor_z"]
        return Opening(ctx.object_pose(self.obj), (geo["front_x"] - q, hxi), hyi, floor, floor + depth, q)

@dataclass(frozen=True)
class HandleDrive:
    """Move ``slide`` by its handle: open, pre-grasp, approach, settle, grip, move holding it, release, back
    off.

    The segments are named ``tag`` + ``open``, ``pre``, ``approach``, ``settle``, ``grip``, ``move``,
    ``release``, ``back``; their runtime targets (:meth:`target`) are ``handle_pre``, ``handle``, the
    move's end (a name in ``ends``) and ``handle_back``.

    Attributes:
        slide: the articulation.
        touch: pairs that may touch while grasping and releasing (``(("hand", "cabinet"),)``).
        moving: pairs that may also touch while the hand moves it (the planner's copy stays behind).
    """

    slide: Slide
    touch: tuple[tuple[str, str], ...]
    moving: tuple[tuple[str, str], ...] = ()

    def segments(self, tag: str, end: str, *, open_steps: int, settle_steps: int, close_steps: int,
                 speed: float, riders: tuple[str, ...] = ()) -> list[s.MotionSegment]:
        """The drive to runtime target ``end`` (``riders``: objects inside, moving with it; ``speed``: of the
        move)."""
        return [s.gripper(f"{tag}open", "open", steps=open_steps),
                s.free(f"{tag}pre", "handle_pre"),
                s.linear(f"{tag}approach", "handle", allow=self.touch),
                s.hold(f"{tag}settle", steps=settle_steps),
                s.gripper(f"{tag}grip", "close", steps=close_steps),
                s.linear(f"{tag}move", end, gripper="close", allow=self.touch + self.moving, riders=riders,
                         speed=speed),
                s.gripper(f"{tag}release", "open", steps=open_steps),
                s.linear(f"{tag}back", "handle_back", allow=self.touch)]

    def arm_path(self, ctx: Context, grasp: Grasp, *, by: float, standoff: float, rng: np.random.Generator,
                 allowed: AllowedContacts) -> list[np.ndarray]:
        """The arm's path moving the slide ``by`` m with handle grasp ``grasp``, as the executor will plan it
        from the commanded configuration (:func:`~mgdata.skeleton.reach.arm_path`, the pairs in ``allowed``
        may touch): the pre-grasp ``standoff`` m back, the handle, the handle moved, ``standoff`` m back from
        there. The planner is synced to the live scene first."""
        ctx.planner.sync(ctx.scene.data)
        pose = self.slide.handle(ctx, grasp)
        moved = Pose(pose.pos + self.slide.axis(ctx) * by, pose.quat)
        return arm_path(ctx, [backed_off(pose, standoff), pose, moved, backed_off(moved, standoff)], rng,
                        q0=ctx.q_cmd, allowed=allowed)

    def target(self, ctx: Context, name: str, grasp: Grasp, *, standoff: float, retreat: float,
               ends: Mapping[str, float]) -> Pose | None:
        """Runtime target ``name`` for handle grasp ``grasp``: ``handle_pre`` (``standoff`` m back),
        ``handle``, ``handle_back`` (``retreat`` m back from the commanded TCP) or an end in ``ends`` (name ->
        the slide position it drives to); None for another name."""
        if name in ends:
            return self.slide.handle_at(ctx, grasp, ends[name])
        if name == "handle_back":
            return backed_off(ctx.commanded_tcp(), retreat)
        if name in ("handle", "handle_pre"):
            pose = self.slide.handle(ctx, grasp)
            return pose if name == "handle" else backed_off(pose, standoff)
        return None
