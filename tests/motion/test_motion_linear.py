"""Straight TCP lines by chained IK (orientation held or slerped), speed caps, failures, reverse replay."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.motion import AllowedContacts, MotionFailure, MotionPlanner, Pose
from mgdata.motion.cartesian import line_deviation, slerp
from mgdata.sim.robot import HOME_Q
from tests.helpers.motion_scenes import TOP_DOWN, down_pose


@pytest.fixture(scope="module")
def q_above(planner: MotionPlanner) -> np.ndarray:
    """Top-down, 20 cm above the table, clear of the wall and the box."""
    return planner.ik(down_pose(0.6, 0.35, 0.2), HOME_Q, np.random.default_rng(0), collision_free=True)


def test_line_holds_orientation_and_stays_on_the_line(planner: MotionPlanner, q_above: np.ndarray) -> None:
    start = planner.fk(q_above)
    target = down_pose(0.68, 0.4, 0.08)  # 15 cm diagonal descent
    traj = planner.linear(q_above, target, np.random.default_rng(0), orientation="hold")
    poses = [planner.fk(q) for q in traj.q]
    tcp = np.array([p.pos for p in poses])
    assert traj.q[0].tobytes() == q_above.tobytes()
    assert np.linalg.norm(tcp[-1] - target.pos) <= planner.config.ik.pos_tol
    assert max(start.angle_to(p) for p in poses) < 0.01  # rad
    assert line_deviation(tcp, start.pos, target.pos) < 0.002  # m
    # the line is dense in between samples too: check the joint-space chords at 10 points each
    mid = [planner.fk(a + t * (b - a)).pos for a, b in zip(traj.q[:-1], traj.q[1:], strict=True)
           for t in np.linspace(0, 1, 10)]
    assert line_deviation(np.array(mid), start.pos, target.pos) < 0.003


def test_line_speed_is_capped(planner: MotionPlanner, q_above: np.ndarray) -> None:
    traj = planner.linear(q_above, down_pose(0.6, 0.35, 0.05), np.random.default_rng(0))
    tcp = np.array([planner.fk(q).pos for q in traj.q])
    speed = np.linalg.norm(np.diff(tcp, axis=0), axis=1) * traj.rate
    cap = planner.config.linear.speed
    assert speed.max() <= cap * 1.02
    assert speed.max() >= cap * 0.8  # and it does travel near the cap on a 15 cm line
    qd = np.diff(traj.q, axis=0) * traj.rate
    assert np.all(np.abs(qd) <= planner.vmax * 1.02)


def test_line_with_slerp_turns_to_the_target_orientation(planner: MotionPlanner, q_above: np.ndarray) -> None:
    start = planner.fk(q_above)
    yaw = Pose(np.zeros(3), np.array([np.cos(0.4), 0.0, 0.0, np.sin(0.4)]))  # 0.8 rad about world z
    target = Pose(start.pos + np.array([0.05, 0.0, -0.1]), (yaw @ Pose(np.zeros(3), TOP_DOWN)).quat)
    traj = planner.linear(q_above, target, np.random.default_rng(0), orientation="slerp")
    poses = [planner.fk(q) for q in traj.q]
    assert poses[-1].angle_to(target) <= planner.config.ik.rot_tol
    assert np.linalg.norm(poses[-1].pos - target.pos) <= planner.config.ik.pos_tol
    # orientation follows the slerp at the same fraction of the way along the line
    total = np.linalg.norm(target.pos - start.pos)
    for p in poses:
        frac = np.linalg.norm(p.pos - start.pos) / total
        expected = Pose(p.pos, slerp(start.quat, target.quat, float(np.clip(frac, 0, 1))))
        assert p.angle_to(expected) < 0.02


def test_line_into_the_table_fails_unless_that_contact_is_allowed(planner: MotionPlanner,
                                                                 q_above: np.ndarray) -> None:
    into_table = down_pose(0.6, 0.35, -0.02)
    with pytest.raises(MotionFailure) as info:
        planner.linear(q_above, into_table, np.random.default_rng(0))
    assert info.value.stage == "plan_fail" and "table" in info.value.reason
    planner.linear(q_above, into_table, np.random.default_rng(0),
                   allowed=AllowedContacts((("hand", "table"),)))


def test_unreachable_line_is_ik_fail_naming_the_waypoint(planner: MotionPlanner, q_above: np.ndarray) -> None:
    with pytest.raises(MotionFailure) as info:
        planner.linear(q_above, down_pose(1.2, 0.35, 0.2), np.random.default_rng(0))
    assert info.value.stage in ("ik_fail", "path_discontinuity")
    assert "line waypoint" in info.value.reason


def test_line_is_deterministic(planner: MotionPlanner, q_above: np.ndarray) -> None:
    target = down_pose(0.55, 0.4, 0.1)
    a = planner.linear(q_above, target, np.random.default_rng(1))
    b = planner.linear(q_above, target, np.random.default_rng(1))
    assert a.q.tobytes() == b.q.tobytes()


def test_reverse_replays_the_samples_backwards(planner: MotionPlanner, q_above: np.ndarray) -> None:
    down = planner.linear(q_above, down_pose(0.6, 0.35, 0.1), np.random.default_rng(0))
    up = planner.reverse(down)
    np.testing.assert_array_equal(up.q, down.q[::-1])
    assert up.q[-1].tobytes() == q_above.tobytes() and up.duration == down.duration
    assert np.linalg.norm(planner.fk(up.q[0]).pos - np.array([0.6, 0.35, 0.1])) < 1e-3


# A lift straight up from a low top-down grasp near the base, on the arm's flipped-shoulder branch (joint 1 at
# 128°, joint 3 at -147°): the dusty family's sponge lift of task 18, draw 0. Near the top the redundant
# joints swing fast (joint 3 by 0.2 rad over the 5 mm step), continuously.
SINGULAR_Q = np.array([2.23832808, -0.42976816, -2.56949757, -2.62600226, -1.00418712, 2.87069363,
                       -1.73265779])
SINGULAR_LIFT = 0.0912  # m


def test_a_fast_but_continuous_passage_is_refined_not_a_discontinuity() -> None:
    """A step whose joints jump past ``max_joint_step`` is halved until they don't: the line then holds
    every intermediate point on the straight line (checked with raw MuJoCo kinematics), no step jumps, and
    without the refinement the same line is a ``path_discontinuity``."""
    import dataclasses

    import mujoco

    from mgdata.motion import MotionConfig
    from mgdata.sim.robot import TCP_SITE
    from tests.helpers.motion_scenes import home_data, scene

    model = scene(wall=False)
    config = MotionConfig()
    coarse = dataclasses.replace(config, linear=dataclasses.replace(config.linear, refine_depth=0))
    start = None
    for cfg in (coarse, config):
        mp = MotionPlanner(model, cfg)
        mp.sync(home_data(model))
        start = mp.fk(SINGULAR_Q)
        target = Pose(start.pos + np.array([0.0, 0.0, SINGULAR_LIFT]), start.quat)
        if cfg is coarse:
            with pytest.raises(MotionFailure) as info:
                mp.line(SINGULAR_Q, target, np.random.default_rng(0))
            assert info.value.stage == "path_discontinuity"
            continue
        line = mp.line(SINGULAR_Q, target, np.random.default_rng(0))
    assert start is not None
    steps = len(line.q) - 1
    assert steps > SINGULAR_LIFT / config.linear.step + 1  # refined: more points than the 5 mm grid
    assert np.max(np.abs(np.diff(line.q, axis=0))) <= config.linear.max_joint_step
    data = mujoco.MjData(model)
    site = model.site(TCP_SITE).id
    tcp, rot_err = [], []
    for q in line.q:  # raw MuJoCo forward kinematics of every waypoint
        data.qpos[:7] = q
        mujoco.mj_kinematics(model, data)
        tcp.append(data.site_xpos[site].copy())
        rel = start.rotation().T @ data.site_xmat[site].reshape(3, 3)
        rot_err.append(np.arccos(np.clip((np.trace(rel) - 1) / 2, -1, 1)))
    tcp = np.array(tcp)
    assert line_deviation(tcp, start.pos, start.pos + np.array([0.0, 0.0, SINGULAR_LIFT])) < 1e-3
    assert np.all(np.diff(tcp[:, 2]) > 0)  # monotonically up
    assert abs(tcp[-1, 2] - start.pos[2] - SINGULAR_LIFT) < 1e-3
    assert max(rot_err) < 0.01
