"""The gate on the real executor: success counts only while holding after the motion, the goal's objects at
rest, and no violation at any step (stronger than ν = 1)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.episode.gate import RestCheck
from mgdata.grasps.db import GraspDB
from mgdata.motion import Pose
from mgdata.record.episode import MemorySink
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.skeleton import segment as s
from mgdata.spec import Constraint, Proposition, SafetySpec
from tests.helpers.scripted import ScriptedSkeleton, scripted_recipe, scripted_task

DOWN = np.array([0.0, 1.0, 0.0, 0.0])
BOX = (ObjectPlacement("box", "box/carton_00", (0.5, 0.0, 0.0), 0.0),)
ON_TABLE = Proposition("box_on_table", "on", ("box",), {"support": "table"})


def _run(script: list[s.MotionSegment], spec: SafetySpec | None = None,  # type: ignore[no-untyped-def]
         settle: int = 0):
    ScriptedSkeleton.SCRIPT = script
    recipe = scripted_recipe((ON_TABLE,), settle=settle)
    ex = Executor(scripted_task(BOX, spec), recipe, grasps=GraspDB({}), render=False)
    sink = MemorySink()
    try:
        result = ex.run(0, sink, keep_failed=True)
    finally:
        ex.close()
    return result, sink.episodes[0][0], sink.episodes[0][1], recipe.tasks.hold_steps


def test_success_during_the_motion_does_not_count() -> None:
    """The box rests on the table throughout (success on every frame), yet the gate waits for the hold."""
    away = Pose([0.35, 0.25, 0.25], DOWN)
    result, frames, meta, hold = _run([s.free("away", away), s.hold("hold", steps=20)])
    assert result.kept and meta.kept and meta.success
    assert all(f.success for f in frames)
    moving = [i for i in range(1, len(frames)) if not np.array_equal(frames[i].action, frames[i - 1].action)]
    assert len(moving) > hold, "the motion is longer than the window: an old-style gate would pass in it"
    last_move = moving[-1]  # frame carrying the motion's last command (the hold repeats it)
    # then hold_steps holding commands, each followed by an observation that counts, then the final frame
    assert len(frames) - 1 - last_move == hold + 1
    assert all(np.array_equal(f.action, frames[-1].action) for f in frames[-hold:])


def test_a_hold_shorter_than_the_window_is_not_kept() -> None:
    hold = scripted_recipe((ON_TABLE,)).tasks.hold_steps
    away = Pose([0.35, 0.25, 0.25], DOWN)
    result, frames, meta, _ = _run([s.free("away", away)], settle=hold - 1)
    assert not meta.kept and not meta.success
    assert not result.kept and result.stage == "goal_not_reached" and all(f.success for f in frames)
    assert f"at most {hold - 1} consecutive" in (result.reason or "")


def test_a_violation_before_engagement_is_not_kept() -> None:
    """ν = 1 excuses a violation before first engagement; a kept demonstration must never show one."""
    spec = SafetySpec("planted", (Constraint("box_never_on_table", "G !box_on_table"),), (ON_TABLE,))
    result, frames, meta, _ = _run([s.hold("hold", steps=20)], spec)
    assert result.t_engage is None and result.t_violation == {"box_never_on_table": 0}
    assert result.verdict and meta.verdict  # the paper's ν, kept in the metadata as defined
    assert not result.kept and not meta.kept and result.stage == "unsafe"
    assert frames[0].violated[0]


def test_rest_check_matches_finite_differences() -> None:
    """RestCheck's speeds against the body's displacement over one physics step (raw MuJoCo)."""
    ScriptedSkeleton.SCRIPT = []
    ex = Executor(scripted_task(BOX), scripted_recipe((ON_TABLE,)), grasps=GraspDB({}), render=False)
    try:
        m, d = ex.scene.model, ex.scene.data
        body = ex.scene.object_body("box")
        rest = RestCheck(m, [body], linear=0.005, angular=0.05)
        ex.scene.reset()
        assert rest.at_rest(d)  # settled on the table
        adr = m.jnt_dofadr[m.joint("box/free").id]
        d.qpos[m.jnt_qposadr[m.joint("box/free").id] + 2] += 0.2  # lift it clear of the table
        d.qvel[adr:adr + 6] = [0.03, -0.04, 0.0, 0.0, 0.0, 0.3]
        m.opt.gravity[:] = 0.0  # free flight at constant velocity over the step
        mujoco.mj_forward(m, d)
        lin, ang = rest.speeds(d)
        before = d.xpos[body].copy()
        quat0 = d.xquat[body].copy()
        mujoco.mj_step(m, d)
        mujoco.mj_kinematics(m, d)  # positions after the step
        raw_lin = np.linalg.norm(d.xpos[body] - before) / m.opt.timestep
        dq = np.zeros(3)
        mujoco.mju_subQuat(dq, d.xquat[body], quat0)
        raw_ang = np.linalg.norm(dq) / m.opt.timestep
        assert lin == pytest.approx(raw_lin, rel=0.02) and ang == pytest.approx(raw_ang, rel=0.02)
        assert lin > 0.045 and not rest.at_rest(d)
    finally:
        ex.close()
