"""Segment kinds executed by the real executor on simple MuJoCo scenes (planner, physics, recorder)."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.engine.executor import Executor, slowed
from mgdata.grasps.db import GraspDB
from mgdata.motion import JointTrajectory, Pose
from mgdata.record.episode import MemorySink
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.skeleton import segment as s
from mgdata.spec import Proposition
from tests.helpers.scripted import ScriptedSkeleton, scripted_recipe, scripted_task

DOWN = np.array([0.0, 1.0, 0.0, 0.0])  # TCP pointing straight down
NEVER = (Proposition("box_dropped", "dropped", ("box",), {"floor_margin": 0.05}),)


def _run(script: list[s.MotionSegment],
         objects: tuple[ObjectPlacement, ...]) -> tuple[Executor, MemorySink, object]:
    ScriptedSkeleton.SCRIPT = script
    ex = Executor(scripted_task(objects), scripted_recipe(NEVER), grasps=GraspDB({}), render=False)
    sink = MemorySink()
    result = ex.run(0, sink, keep_failed=True)
    return ex, sink, result


def _tcp_path(ex: Executor, sink: MemorySink) -> list[Pose]:
    frames = sink.episodes[0][0]
    return [ex.planner.fk(f.state[:7].astype(np.float64)) for f in frames]


@pytest.fixture(scope="module")
def wall() -> tuple[ObjectPlacement, ...]:
    return (ObjectPlacement("box", "box/carton_00", (0.5, 0.0, 0.0), 0.0),)


def test_free_motion_goes_around_an_obstacle(wall: tuple[ObjectPlacement, ...]) -> None:
    a, b = Pose([0.5, 0.17, 0.07], DOWN), Pose([0.5, -0.17, 0.07], DOWN)
    ex, sink, result = _run([s.free("a", a), s.free("b", b)], wall)
    try:
        assert result.stage == "goal_not_reached"  # every segment ran; the (impossible) goal never held
        frames = sink.episodes[0][0]
        assert not any(f.engaged for f in frames), "the robot touched the box"
        assert np.linalg.norm(_tcp_path(ex, sink)[-1].pos - b.pos) < 0.01
        # The straight joint-space move between the two ends would have hit the box.
        rng = np.random.default_rng(0)
        ex.scene.reset()
        ex.planner.sync(ex.scene.data)
        qa = ex.planner.ik(a, ex.scene.arm_q(), rng)
        qb = ex.planner.ik(b, qa, rng)
        assert ex.planner.checker.first_invalid(np.stack([qa, qb]), 0.01) is not None
    finally:
        ex.close()


def test_linear_keeps_orientation_reverse_returns_gripper_and_hold(wall: tuple[ObjectPlacement, ...]) -> None:
    start = Pose([0.40, 0.15, 0.20], DOWN)
    end = Pose([0.55, 0.25, 0.15], Pose.identity().quat)  # its orientation is ignored by "hold"
    script = [s.free("start", start), s.hold("settle", steps=10), s.linear("line", end),
              s.reverse("back", of="line"), s.gripper("close", "close", steps=15),
              s.hold("wait", steps=7, gripper="close")]
    ex, sink, result = _run(script, wall)
    try:
        frames = sink.episodes[0][0]
        assert len(frames) == result.steps + 1
        path = _tcp_path(ex, sink)
        # find the line: the samples after the settle whose TCP is on the way from start to end
        direction = (end.pos - start.pos) / np.linalg.norm(end.pos - start.pos)
        moving = [p for p in path if 0.01 < np.dot(p.pos - start.pos, direction) < 0.17]
        assert len(moving) > 5
        for p in moving:
            assert p.angle_to(start) < 0.03, "linear segment turned the TCP"
            off_line = (p.pos - start.pos) - np.dot(p.pos - start.pos, direction) * direction
            assert np.linalg.norm(off_line) < 0.01
        farthest = max(np.dot(p.pos - start.pos, direction) for p in path)
        assert farthest > 0.17  # it got (nearly) to the end, 0.187 m away
        assert np.linalg.norm(path[-1].pos - start.pos) < 0.01  # reversed back to the start
        assert frames[-1].state[7] < 0.005 < frames[0].state[7]  # the gripper closed on nothing
        assert all(f.action[7] == 1.0 for f in frames[-7:])
    finally:
        ex.close()


def test_unreachable_target_fails_with_a_stage(wall: tuple[ObjectPlacement, ...]) -> None:
    ex, sink, result = _run([s.free("far", Pose([1.6, 0.0, 0.3], DOWN))], wall)
    try:
        assert result.stage == "ik_fail" and result.segment == "far" and not result.kept
        assert "no solution" in (result.reason or "")
        assert len(sink.episodes[0][0]) == 1  # nothing executed: only the initial observation
    finally:
        ex.close()


def test_slowed_trajectory_keeps_the_path_and_stretches_time() -> None:
    q = np.linspace(0.0, 1.0, 11)[:, None] * np.ones((1, 7))
    traj = JointTrajectory(q, 20.0, 0.5)
    half = slowed(traj, 0.5)
    assert half.duration == pytest.approx(1.0)
    assert len(half) == 21
    assert np.allclose(half.q[0], q[0]) and np.allclose(half.q[-1], q[-1])
    assert np.max(np.abs(np.diff(half.q, axis=0))) == pytest.approx(0.05)
    assert slowed(traj, 1.0) is traj
