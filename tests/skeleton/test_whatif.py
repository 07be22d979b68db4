"""What-if state: the planner sees a changed scene inside the block, the live one after; the live variant
restores the live state exactly."""

from __future__ import annotations

import numpy as np

from mgdata.motion import Pose
from mgdata.skeleton.context import Context
from mgdata.skeleton.whatif import keeps_clear, live_what_if, planner_what_if


def _adr(ctx: Context, obj: str) -> int:
    m = ctx.scene.model
    return int(m.jnt_qposadr[m.body_jntadr[ctx.scene.object_body(obj)]])


def test_planner_what_if_moves_only_the_planners_copy(ctx: Context) -> None:
    live = ctx.scene.data.qpos.copy()
    adr, drawer = _adr(ctx, "obstacle"), ctx.scene.articulation_qpos_adr("cabinet")
    spot = Pose(np.array([0.45, -0.3, 0.8]), np.array([1.0, 0.0, 0.0, 0.0]))
    with planner_what_if(ctx, objects={"obstacle": spot}, articulations={"cabinet": 0.1}):
        seen = ctx.planner.checker.data.qpos
        assert np.allclose(seen[adr:adr + 3], spot.pos) and seen[drawer] == 0.1
        assert np.array_equal(ctx.scene.data.qpos, live)
    assert np.array_equal(ctx.planner.checker.data.qpos, live)
    with planner_what_if(ctx, objects={"target": np.array([0.5, -0.25, 0.8])}):
        q = ctx.planner.checker.data.qpos
        t = _adr(ctx, "target")
        assert np.allclose(q[t:t + 3], [0.5, -0.25, 0.8])
        assert np.array_equal(q[t + 3:t + 7], live[t + 3:t + 7])


def test_live_what_if_restores_the_live_state(ctx: Context) -> None:
    live, handle = ctx.scene.data.qpos.copy(), ctx.scene.model.body("cabinet/drawer").id
    closed_x = ctx.scene.data.xpos[handle].copy()
    adr = ctx.scene.articulation_qpos_adr("cabinet")
    with live_what_if(ctx, {"cabinet": 0.12}):
        assert ctx.scene.data.qpos[adr] == 0.12
        assert np.isclose(np.linalg.norm(ctx.scene.data.xpos[handle] - closed_x), 0.12)  # kinematics ran
    assert np.array_equal(ctx.scene.data.qpos, live) and np.allclose(ctx.scene.data.xpos[handle], closed_x)


def test_keeps_clear_sees_an_object_put_on_the_arm(ctx: Context) -> None:
    path = ctx.q_cmd[None]
    assert keeps_clear(ctx, "obstacle", path, 0.01)
    hand = ctx.planner.fk(ctx.q_cmd)
    on_hand = Pose(hand.pos - np.array([0.0, 0.0, 0.05]), np.array([1.0, 0.0, 0.0, 0.0]))
    with planner_what_if(ctx, objects={"obstacle": on_hand}):
        assert not keeps_clear(ctx, "obstacle", path, 0.01)
