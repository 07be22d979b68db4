"""What-if state: check something in a changed scene (an object moved, a drawer opened), then restore.

Two kinds:

* :func:`planner_what_if`: only the planner's private copy of the scene changes (objects put elsewhere,
  articulations set); the live scene is not touched. For checks by IK and collision queries.
* :func:`live_what_if`: the live scene itself has its articulations set (forward kinematics run) and the
  planner synced to it; both are restored afterwards. For checks that read the live state (object poses).

Example::

    with planner_what_if(ctx, objects={"bottle": spot_pose}, articulations={"cabinet": 0.2}):
        clear = planner.checker.valid(q)
    # here the planner sees the live scene again
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from mgdata.motion.types import AllowedContacts, Pose

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context

_STAGED = "whatif/data"
"""``ctx.memo`` key of the staged MjData (allocated once per attempt)."""


def staged_data(ctx: Context, objects: Mapping[str, Pose | np.ndarray],
                articulations: Mapping[str, float]) -> mujoco.MjData:
    """A copy of the live joint and mocap state with ``objects`` moved (a :class:`Pose`, or a position that
    keeps the orientation) and ``articulations`` set (their joint's qpos); no kinematics is run (the
    planner's sync reads joint positions and mocap poses only)."""
    scene = ctx.scene
    m = scene.model
    staged = ctx.memo.get(_STAGED) or mujoco.MjData(m)
    ctx.memo[_STAGED] = staged
    staged.qpos[:] = scene.data.qpos
    staged.mocap_pos[:] = scene.data.mocap_pos
    staged.mocap_quat[:] = scene.data.mocap_quat
    for name, where in objects.items():
        adr = int(m.jnt_qposadr[m.body_jntadr[scene.object_body(name)]])
        if isinstance(where, Pose):
            staged.qpos[adr:adr + 3], staged.qpos[adr + 3:adr + 7] = where.pos, where.quat
        else:
            staged.qpos[adr:adr + 3] = where
    for name, q in articulations.items():
        staged.qpos[scene.articulation_qpos_adr(name)] = q
    return staged


@contextmanager
def planner_what_if(ctx: Context, *, objects: Mapping[str, Pose | np.ndarray] | None = None,
                    articulations: Mapping[str, float] | None = None) -> Iterator[None]:
    """Inside the block the planner sees the live scene with ``objects`` moved and ``articulations`` set
    (:func:`staged_data`); after it, the live scene again."""
    ctx.planner.sync(staged_data(ctx, objects or {}, articulations or {}))
    try:
        yield
    finally:
        ctx.planner.sync(ctx.scene.data)


@contextmanager
def live_what_if(ctx: Context, articulations: Mapping[str, float]) -> Iterator[None]:
    """Inside the block the live scene has ``articulations`` set (forward kinematics run) and the planner is
    synced to it; after it, the old positions are back (forward kinematics run again, the planner synced)."""
    scene = ctx.scene
    adrs = {name: scene.articulation_qpos_adr(name) for name in articulations}
    old = {name: float(scene.data.qpos[adr]) for name, adr in adrs.items()}
    for name, q in articulations.items():
        scene.data.qpos[adrs[name]] = q
    mujoco.mj_forward(scene.model, scene.data)
    try:
        ctx.planner.sync(scene.data)
        yield
    finally:
        for name, q in old.items():
            scene.data.qpos[adrs[name]] = q
        mujoco.mj_forward(scene.model, scene.data)
        ctx.planner.sync(scene.data)


def keeps_clear(ctx: Context, obj: str, path: np.ndarray, margin: float) -> bool:
    """Does the arm at every configuration of ``path`` (N, 7) keep ``margin`` m from ``obj`` (where the
    planner sees it: use inside :func:`planner_what_if` to test a spot)?"""
    checker = ctx.planner.checker
    checker.configure(AllowedContacts(), None, margin)
    return not any(c.body2.split("/")[0] == obj for q in path for c in checker.collisions(q))
