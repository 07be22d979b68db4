"""Random plans in a cluttered scene, each checked by an independent MuJoCo oracle; and determinism across
processes (what parallel workers rely on)."""

from __future__ import annotations

import hashlib
import subprocess
import sys

import numpy as np
import pytest

from mgdata.motion import MotionConfig, MotionFailure, MotionPlanner, Pose
from mgdata.sim.robot import HOME_Q
from tests.helpers.motion_scenes import down_pose, home_data, scene
from tests.helpers.repo import REPO
from tests.motion.test_motion_free import penetrations

STAGES = {"ik_fail", "plan_fail", "retime_fail", "collision_recheck"}


def random_pose(rng: np.random.Generator) -> Pose:
    """A TCP pose above the table, pointing down with a random yaw and up to 30° of tilt."""
    yaw, tilt_axis, tilt = rng.uniform(-np.pi, np.pi), rng.uniform(-np.pi, np.pi), rng.uniform(0, np.pi / 6)
    down = Pose(np.zeros(3), np.array([0.0, 1.0, 0.0, 0.0]))
    turn = Pose(np.zeros(3), np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]))
    lean = Pose(np.zeros(3), np.array([np.cos(tilt / 2), np.cos(tilt_axis) * np.sin(tilt / 2),
                                       np.sin(tilt_axis) * np.sin(tilt / 2), 0.0]))
    pos = np.array([rng.uniform(0.3, 0.7), rng.uniform(-0.45, 0.45), rng.uniform(0.08, 0.45)])
    return Pose(pos, (lean @ turn @ down).quat)


def run_random_plans(n: int, seed: int) -> int:
    """Plans between ``n`` random collision-free IK endpoint pairs; returns how many succeeded and asserts
    that every success is penetration-free and every failure is a MotionFailure with a known stage."""
    model = scene(wall=True, box=True)
    data = home_data(model)
    mp = MotionPlanner(model, MotionConfig())
    mp.sync(data)
    rng = np.random.default_rng(seed)
    ok = pairs = 0
    while pairs < n:
        try:  # random targets may be out of reach or inside the wall: draw again
            qa = mp.ik(random_pose(rng), HOME_Q, rng, collision_free=True)
            qb = mp.ik(random_pose(rng), HOME_Q, rng, collision_free=True)
        except MotionFailure:
            continue
        pairs += 1
        try:
            traj = mp.free(qa, qb, rng)
        except MotionFailure as fail:
            assert fail.stage in STAGES and fail.reason
            continue
        assert traj.q[0].tobytes() == qa.tobytes() and traj.q[-1].tobytes() == qb.tobytes()
        assert penetrations(model, data, traj.q) == []
        ok += 1
    return ok


def test_random_plans_never_collide() -> None:
    assert run_random_plans(5, seed=1) >= 4


@pytest.mark.slow
def test_many_random_plans_never_collide() -> None:
    assert run_random_plans(60, seed=2) >= 57


def fingerprint() -> str:
    """SHA-256 of a seeded free plan and line in the wall scene."""
    model = scene(wall=True, box=True)
    mp = MotionPlanner(model)
    mp.sync(home_data(model))
    rng = np.random.default_rng(3)
    qa = mp.ik(down_pose(0.5, 0.2, 0.15), HOME_Q, rng, collision_free=True)
    qb = mp.ik(down_pose(0.5, -0.2, 0.15), HOME_Q, rng, collision_free=True)
    digest = hashlib.sha256(mp.free(qa, qb, rng).q.tobytes())
    digest.update(mp.linear(qa, down_pose(0.55, 0.25, 0.05), rng).q.tobytes())
    return digest.hexdigest()


def test_same_seed_gives_the_same_bytes_in_another_process() -> None:
    code = (f"import sys; sys.path.insert(0, {str(REPO)!r}); import tests.motion.test_motion_random as t; "
            "print(t.fingerprint())")
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert other.stdout.strip() == fingerprint()
