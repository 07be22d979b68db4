"""IK (mink with seeded restarts) and FK of the TCP, in scenes with the base at and away from the origin."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.motion import NO_CONTACTS, MotionFailure, MotionPlanner, Pose
from mgdata.sim.robot import HOME_Q, TCP_SITE
from tests.helpers.motion_scenes import TOP_DOWN, WALL_HALF, WALL_X, down_pose, scene


def test_fk_matches_the_scene_even_with_a_moved_base() -> None:
    model = scene(wall=False, base_pos=(0.1, -0.2, 0.05), base_yaw=0.5)
    mp = MotionPlanner(model)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(mp.lower, mp.upper)
        data.qpos[:7] = q
        mujoco.mj_kinematics(model, data)
        site = model.site(TCP_SITE).id
        pose = mp.fk(q)
        np.testing.assert_allclose(pose.pos, data.site_xpos[site], atol=1e-9)
        np.testing.assert_allclose(pose.rotation(), data.site_xmat[site].reshape(3, 3), atol=1e-9)


def test_ik_solves_fk_of_random_configurations(planner: MotionPlanner) -> None:
    rng = np.random.default_rng(11)
    solved = 0
    for _ in range(40):
        q_true = planner._ik.clip(HOME_Q + rng.normal(0.0, 0.5, 7))
        target = planner.fk(q_true)
        q = planner.ik(target, HOME_Q, rng)
        reached = planner.fk(q)
        assert np.linalg.norm(reached.pos - target.pos) <= planner.config.ik.pos_tol
        assert reached.angle_to(target) <= planner.config.ik.rot_tol
        assert np.all(q >= planner.lower) and np.all(q <= planner.upper)
        solved += 1
    assert solved == 40


def test_ik_in_a_moved_base_scene_reaches_world_targets() -> None:
    model = scene(wall=False, base_pos=(0.3, 0.2, 0.1), base_yaw=-0.8)
    mp = MotionPlanner(model)
    target = Pose(np.array([0.65, 0.0, 0.25]), TOP_DOWN)
    q = mp.ik(target, HOME_Q, np.random.default_rng(0))
    data = mujoco.MjData(model)
    data.qpos[:7] = q
    mujoco.mj_kinematics(model, data)
    assert np.linalg.norm(data.site_xpos[model.site(TCP_SITE).id] - target.pos) < 1e-3


def test_unreachable_target_fails_with_the_residual(planner: MotionPlanner) -> None:
    with pytest.raises(MotionFailure) as info:
        planner.ik(down_pose(1.8, 0.0, 0.3), HOME_Q, np.random.default_rng(0))
    assert info.value.stage == "ik_fail"
    assert "best residual" in info.value.reason and "[1.8, 0.0, 0.3]" in info.value.reason
    residual = float(info.value.reason.split("best residual ")[1].split(" m")[0])
    assert residual > 0.5  # the arm reaches ~0.85 m; the residual is the real remaining distance


def test_collision_free_ik_rejects_solutions_inside_the_wall(planner: MotionPlanner) -> None:
    inside = down_pose(WALL_X, 0.0, WALL_HALF[2] * 2 - 0.05)  # fingertips 5 cm deep in the wall
    rng = np.random.default_rng(0)
    q = planner.ik(inside, HOME_Q, rng)  # kinematically fine ...
    planner.checker.configure(NO_CONTACTS, None, 0.0)
    assert "wall" in planner.checker.explain(q)  # ... but inside the wall
    with pytest.raises(MotionFailure) as info:
        planner.ik(inside, HOME_Q, rng, collision_free=True)
    assert info.value.stage == "ik_fail" and "wall" in info.value.reason and "rejected" in info.value.reason


def test_ik_is_deterministic_for_a_seed(planner: MotionPlanner) -> None:
    target = down_pose(0.45, -0.3, 0.1)
    far_seed = HOME_Q + np.array([2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # forces restarts
    a = planner.ik(target, far_seed, np.random.default_rng(5))
    b = planner.ik(target, far_seed, np.random.default_rng(5))
    assert a.tobytes() == b.tobytes()


def test_ik_falls_back_to_a_home_seed_when_the_seed_strands_the_solver() -> None:
    """A seed far from the solution (the arm left in a twisted pose by an earlier segment) can strand the
    local solver in every restart; the last attempt starts from the home posture."""
    from mgdata.motion.config import IKConfig
    from mgdata.motion.ik import IKSolver

    config = IKConfig(restarts=0)
    solver = IKSolver(Pose(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])), config)
    target = solver.fk(np.array([0.038, -0.825, 0.192, -2.325, -0.161, 1.679, 1.177]))
    seed = np.array([1.33, 0.154, 2.521, -0.623, -2.877, 3.215, -2.703])
    assert not solver.attempt(target, seed).converged(config)  # the seed alone strands it
    q = solver.solve(target, seed, np.random.default_rng(0))
    data_pose = solver.fk(q)
    assert np.linalg.norm(data_pose.pos - target.pos) <= config.pos_tol
    assert data_pose.angle_to(target) <= config.rot_tol


def test_ik_with_a_limit_margin_returns_only_solutions_that_keep_it(planner: MotionPlanner) -> None:
    """Seeded at a configuration near a joint limit whose own TCP pose is the target, plain IK returns that
    configuration; with ``limit_margin`` the solver takes another restart, and what it returns keeps the
    margin from the model's joint ranges (read raw) and still puts the TCP on the target (raw kinematics)."""
    model = planner.checker.model
    lo, hi = model.jnt_range[:7, 0], model.jnt_range[:7, 1]
    data = mujoco.MjData(model)
    rng = np.random.default_rng(5)
    margin, vetoed, solved = 0.15, 0, 0
    for _ in range(24):
        q_near = HOME_Q + rng.normal(0.0, 0.4, 7)
        j = int(rng.integers(7))
        q_near[j] = hi[j] - 0.05 if rng.random() < 0.5 else lo[j] + 0.05  # 0.05 rad inside a limit
        q_near = np.clip(q_near, lo + 0.01, hi - 0.01)
        target = planner.fk(q_near)
        plain = planner.ik(target, q_near, rng)
        assert np.min(np.minimum(plain - lo, hi - plain)) < margin  # the nearest solution lacks the margin
        try:
            q = planner.ik(target, q_near, rng, limit_margin=margin)
        except MotionFailure as fail:
            assert "from a joint limit" in fail.reason
            vetoed += 1
            continue
        assert np.all(q - lo >= margin - 1e-9) and np.all(hi - q >= margin - 1e-9), (q, lo, hi)
        data.qpos[:7] = q
        mujoco.mj_kinematics(model, data)
        reached = data.site_xpos[model.site(TCP_SITE).id]
        assert np.linalg.norm(reached - target.pos) <= planner.config.ik.pos_tol
        solved += 1
    assert solved >= 12, (solved, vetoed)
