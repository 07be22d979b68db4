"""Pose, JointTrajectory and AllowedContacts: the plain values other layers pass around."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mgdata.motion import AllowedContacts, Attachment, JointTrajectory, Pose

finite = st.floats(-2.0, 2.0, allow_nan=False)
quats = st.tuples(finite, finite, finite, finite).filter(lambda q: np.linalg.norm(q) > 0.1)


@given(pos=st.tuples(finite, finite, finite), quat=quats)
def test_pose_matrix_round_trip(pos: tuple, quat: tuple) -> None:
    pose = Pose(np.array(pos), np.array(quat))
    again = Pose.from_matrix(pose.matrix())
    np.testing.assert_allclose(again.pos, pose.pos, atol=1e-12)
    sign = 1.0 if np.dot(again.quat, pose.quat) >= 0 else -1.0  # q and -q are the same rotation
    np.testing.assert_allclose(sign * again.quat, pose.quat, atol=1e-9)
    assert abs(np.linalg.norm(pose.quat) - 1.0) < 1e-12 and pose.quat[0] >= 0.0
    R = pose.rotation()
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


@given(a=st.tuples(finite, finite, finite, finite), qa=quats, qb=quats)
def test_pose_composition_is_matrix_product(a: tuple, qa: tuple, qb: tuple) -> None:
    pa, pb = Pose(np.array(a[:3]), np.array(qa)), Pose(np.array(a[1:]), np.array(qb))
    np.testing.assert_allclose((pa @ pb).matrix(), pa.matrix() @ pb.matrix(), atol=1e-9)
    np.testing.assert_allclose((pa @ pa.inverse()).matrix(), np.eye(4), atol=1e-9)
    assert pa.angle_to(pa @ pb) == pytest.approx(Pose.identity().angle_to(pb), abs=1e-6)


def test_pose_quaternion_is_wxyz() -> None:
    half_turn_about_z = Pose(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
    np.testing.assert_allclose(half_turn_about_z.rotation(), np.diag([-1.0, -1.0, 1.0]), atol=1e-12)
    np.testing.assert_array_equal(Pose(np.zeros(3), np.array([-2.0, 0, 0, 0])).quat, [1.0, 0, 0, 0])
    with pytest.raises(ValueError, match="non-zero quaternion"):
        Pose(np.zeros(3), np.zeros(4))


def test_joint_trajectory_shape_times_and_reverse() -> None:
    q = np.arange(21, dtype=float).reshape(3, 7)
    traj = JointTrajectory(q, 20.0, 0.08)
    np.testing.assert_allclose(traj.times, [0.0, 0.05, 0.08])
    back = traj.reversed()
    np.testing.assert_array_equal(back.q, q[::-1])
    assert back.duration == traj.duration and back.rate == traj.rate
    with pytest.raises(ValueError, match=r"\(N, 7\)"):
        JointTrajectory(np.zeros((3, 6)), 20.0, 0.1)
    with pytest.raises(ValueError):
        traj.q[0, 0] = 1.0  # read-only: trajectories are shared values


def test_allowed_contacts_and_attachment_validate() -> None:
    both = AllowedContacts((("hand", "box"),)) + AllowedContacts((("box", "table"),))
    assert both.pairs == (("hand", "box"), ("box", "table"))
    with pytest.raises(ValueError, match="body, body"):
        AllowedContacts((("hand",),))
    with pytest.raises(ValueError, match="4x4"):
        Attachment("box", np.eye(3))
