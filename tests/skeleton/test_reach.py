"""Reach tests: a straight-down hand over a point, the arm's path through poses, a grasp's reach."""

from __future__ import annotations

import numpy as np

from mgdata.motion import NO_CONTACTS, Pose
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import raised
from mgdata.skeleton.reach import arm_path, reaches_down, reaches_grasp


def test_reaches_down_near_the_robot_not_beyond_its_reach(ctx: Context) -> None:
    rng, tcp = np.random.default_rng(0), ctx.commanded_tcp().pos
    assert reaches_down(ctx, tcp - np.array([0.0, 0.0, 0.05]), rng, clearance=0.0)  # below the start pose
    assert not reaches_down(ctx, np.array([2.0, 0.0, tcp[2]]), rng, clearance=0.0)


def test_arm_path_stops_at_the_first_part_that_does_not_solve(ctx: Context) -> None:
    rng = np.random.default_rng(1)
    tcp = ctx.commanded_tcp()
    up, far = raised(tcp, 0.05), Pose(tcp.pos + np.array([2.0, 0.0, 0.0]), tcp.quat)
    path = arm_path(ctx, [tcp, up, raised(tcp, 0.1)], rng, q0=ctx.q_cmd, allowed=NO_CONTACTS)
    assert len(path) == 3 and path[0].shape == (1, 7)
    assert np.allclose(ctx.planner.fk(path[-1][-1]).pos, raised(tcp, 0.1).pos, atol=1e-3)
    assert len(arm_path(ctx, [tcp, far, up], rng, q0=ctx.q_cmd, allowed=NO_CONTACTS)) == 1
    assert len(arm_path(ctx, [tcp, up], rng, q0=ctx.q_cmd, allowed=NO_CONTACTS, with_start=False)) == 1


def test_reaches_grasp(ctx: Context) -> None:
    rng = np.random.default_rng(2)
    assert reaches_grasp(ctx, raised(ctx.commanded_tcp(), -0.05), 0.05, rng, allowed=NO_CONTACTS)
    far = Pose(ctx.commanded_tcp().pos + np.array([2.0, 0.0, 0.0]), ctx.commanded_tcp().quat)
    assert not reaches_grasp(ctx, far, 0.05, rng, allowed=NO_CONTACTS)
