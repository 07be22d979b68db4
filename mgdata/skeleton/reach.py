"""Reach tests a skeleton runs before committing to a spot: a straight-down hand over a point, the arm's
path through later poses.

Example::

    ok = reaches_down(ctx, np.array([0.5, -0.2, 0.9]), ctx.task_rng("pile_reach_down"), clearance=0.02)
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from mgdata.motion import AllowedContacts, MotionFailure, Pose
from mgdata.sim.robot import ROOT_BODY
from mgdata.skeleton.poses import backed_off

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context

DOWN_QUATS = ((0.0, 1.0, 0.0, 0.0), (0.0, 0.7071067811865476, 0.7071067811865476, 0.0))
"""A TCP pointing straight down, at either roll about the vertical (0° and 90°)."""


def reaches_down(ctx: Context, pos: np.ndarray, rng: np.random.Generator, *, clearance: float) -> bool:
    """Does a straight-down hand (either roll of :data:`DOWN_QUATS`) reach ``pos`` (IK from the commanded
    configuration) with the arm ``clearance`` m clear of everything but the table (the table may be near: a
    low object is put down close to it)?"""
    planner = ctx.planner
    for quat in DOWN_QUATS:
        try:
            q = planner.ik(Pose(pos, np.array(quat)), ctx.q_cmd, rng)
        except MotionFailure:
            continue
        planner.checker.configure(AllowedContacts(((ROOT_BODY, "table"),)), None, clearance)
        if planner.checker.valid(q):
            return True
    return False


def arm_path(ctx: Context, poses: Sequence[Pose], rng: np.random.Generator, *, q0: np.ndarray,
             allowed: AllowedContacts, with_start: bool = True) -> list[np.ndarray]:
    """The arm's path (one (n, 7) block per part) through ``poses`` as the executor would plan it: IK to the
    first from ``q0``, then straight lines through the rest (``allowed`` may touch). It stops at the first
    part that does not solve and returns the parts before it. ``with_start``: the IK solution is a part of
    its own (else only the lines are).

    Example::

        later = arm_path(ctx, [pre, grasp, pulled], rng, q0=ctx.q_cmd, allowed=NO_CONTACTS)
    """
    planner, path = ctx.planner, []
    with contextlib.suppress(MotionFailure):  # the rest is left out: the executor fails on it anyway
        q = planner.ik(poses[0], q0, rng)
        if with_start:
            path.append(q[None])
        for goal in poses[1:]:
            q_line = planner.line(q, goal, rng, allowed=allowed).q
            path.append(q_line)
            q = q_line[-1]
    return path


def reaches_grasp(ctx: Context, grasp_tcp: Pose, standoff: float, rng: np.random.Generator, *,
                  allowed: AllowedContacts) -> bool:
    """Do the pre-grasp (``standoff`` m back along the approach) and then the grasp pose ``grasp_tcp`` have
    collision-free IK solutions (the pairs in ``allowed`` may touch), from the commanded configuration?"""
    try:
        q = ctx.planner.ik(backed_off(grasp_tcp, standoff), ctx.q_cmd, rng, collision_free=True,
                           allowed=allowed)
        ctx.planner.ik(grasp_tcp, q, rng, collision_free=True, allowed=allowed)
    except MotionFailure:
        return False
    return True
