"""Pose idioms: backing off along the approach axis, straight up, yaw quaternions, rotations about an axis,
the held object's pose."""

from __future__ import annotations

import math

import numpy as np

from mgdata.motion import Pose
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import (
    UP,
    about_z,
    backed_off,
    held_object,
    horizontal_unit,
    raised,
    rotation_about,
    upright,
    yaw_of,
)


def _pose(pos: tuple[float, float, float], rot: np.ndarray) -> Pose:
    return Pose.from_pos_mat(np.array(pos), rot)


def test_backed_off_moves_against_the_tcp_approach_axis_only() -> None:
    down = _pose((0.4, 0.1, 0.3), np.diag([1.0, -1.0, -1.0]))  # TCP +Z pointing down
    pre = backed_off(down, 0.1)
    assert np.allclose(pre.pos, [0.4, 0.1, 0.4]) and np.allclose(pre.quat, down.quat)
    side = _pose((0.0, 0.0, 0.0), rotation_about(np.array([0.0, 1.0, 0.0]), math.pi / 2))  # +Z along world +X
    assert np.allclose(backed_off(side, 0.05).pos, [-0.05, 0.0, 0.0])


def test_raised_moves_straight_up_whatever_the_orientation() -> None:
    tilted = _pose((0.1, 0.2, 0.3), rotation_about(np.array([1.0, 1.0, 0.0]), 0.7))
    up = raised(tilted, 0.25)
    assert np.allclose(up.pos, [0.1, 0.2, 0.55]) and np.allclose(up.quat, tilted.quat)


def test_about_z_and_yaw_of_agree_and_upright_drops_the_tilt() -> None:
    for yaw in (-3.0, -1.2, 0.0, 0.4, 2.9):
        assert math.isclose(yaw_of(Pose(np.zeros(3), about_z(yaw))), yaw, abs_tol=1e-12)
        rot = Pose(np.zeros(3), about_z(yaw)).rotation()
        assert np.allclose(rot[:, 2], UP) and np.allclose(rot[:2, 0], [math.cos(yaw), math.sin(yaw)])
    tipped = Pose.from_pos_mat(np.zeros(3), rotation_about(np.array([1.0, 0.0, 0.0]), 0.3)
                               @ Pose(np.zeros(3), about_z(1.0)).rotation())
    stood = Pose(np.zeros(3), upright(tipped.quat)).rotation()
    assert np.allclose(stood[:, 2], UP) and math.isclose(yaw_of(Pose(np.zeros(3), upright(tipped.quat))),
                                                         yaw_of(tipped), abs_tol=1e-9)


def test_rotation_about_is_a_proper_rotation_fixing_its_axis() -> None:
    axis = np.array([0.3, -0.5, 0.8])
    r = rotation_about(axis, 1.1)
    assert np.allclose(r @ r.T, np.eye(3)) and math.isclose(np.linalg.det(r), 1.0)
    assert np.allclose(r @ axis, axis)
    assert math.isclose(math.acos((np.trace(r) - 1) / 2), 1.1)


def test_horizontal_unit() -> None:
    assert np.allclose(horizontal_unit(np.array([0.0, -2.0, 5.0])), [0.0, -1.0])
    assert np.allclose(horizontal_unit(np.array([0.0, 0.0, 1.0])), [0.0, 0.0])


def test_held_object_maps_the_objects_pose_to_the_tcp_pose(ctx: Context) -> None:
    held = held_object(ctx, "target")
    assert held.attachment.body == "target"
    assert np.allclose(held.tcp_for(ctx.object_pose("target")).matrix(), ctx.tcp_pose().matrix(), atol=1e-9)
    moved = Pose(ctx.object_pose("target").pos + np.array([0.1, 0.0, 0.05]), ctx.object_pose("target").quat)
    assert np.allclose(held.tcp_for(moved).pos, ctx.tcp_pose().pos + np.array([0.1, 0.0, 0.05]), atol=1e-9)
