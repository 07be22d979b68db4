"""Scripted teleop sessions end to end: emulated leader → real SDK → session → recorder/monitor/gate →
dataset; ``mgdata validate`` accepts it; replaying the raw leader stream gives the same bytes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mgdata.record.reader import DatasetReader
from mgdata.record.validate import validate_dataset
from mgdata.sim.robot import HOME_Q
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.emulator.arms import ArmBuild, ManualClock
from mgdata.teleop.emulator.operator import calibrate_so101, so101_calibration_scripts
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.gello import GelloCalibration
from mgdata.teleop.live import replay_episode
from mgdata.teleop.so101.calibration import so101_motors
from mgdata.teleop.stream import LeaderStream, stream_path
from tests.helpers.teleop import GELLO_BUILD
from tests.teleop.scripted import run_scripted_session
from tests.teleop.so101_demo import operator_script


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _check_replay(dataset: Path, tmp_path: Path) -> None:
    replayed = tmp_path / "replayed"
    replay_episode(dataset, 0, replayed)
    assert _files(replayed.with_name("replayed_failed")) == _files(dataset)


def test_gello_session_records_labelled_episode_and_replays_byte_identical(gello_cal: GelloCalibration,
                                                                            tmp_path: Path) -> None:
    # the operator swings joint 1 and bends joint 4, then presses Stop: the goal is not reached
    scripts = [JointScript([0, 0.2, 1.2], [HOME_Q[k], HOME_Q[k], HOME_Q[k] + (0.3 if k in (0, 3) else 0.0)])
               for k in range(7)] + [JointScript.constant(0.0)]
    out = tmp_path / "jar_teleop"
    cal_file = tmp_path / "gello.json"
    gello_cal.save(cal_file)
    session = run_scripted_session("gello", GELLO_BUILD, cal_file.read_text(), scripts, out, stop_at=30)
    failed = out.with_name("jar_teleop_failed")
    assert session.stored == [(False, 0)]
    report = validate_dataset(failed)
    assert report.ok, report.problems
    meta = DatasetReader(failed).record(0).meta
    stream = LeaderStream.load(stream_path(failed, 0))
    assert stream.arm == "gello" and len(stream.step_sample) == 30
    assert len(stream.times) >= 30  # the reader thread logged at least one reading per control step
    # the commanded joints follow the leader: 1:1 mirror of the calibrated reading (step-limited)
    final = stream.ticks[stream.step_sample[-1]]
    assert np.allclose(gello_cal.joints_q(final)[[0, 3]], HOME_Q[[0, 3]] + 0.3, atol=0.01)
    assert meta.source == "gello" and not meta.kept and meta.failure_stage == "goal_not_reached"
    # the loop ran on an absolute 20 Hz grid: every step was due a whole number of periods after the
    # previous one (more than one only where slots were skipped after an overrun) and never started early
    periods = np.diff(session.step_due) / session.dt
    assert np.allclose(periods, np.rint(periods), atol=1e-6) and (np.rint(periods) >= 1).all()
    assert int(np.rint(periods).sum()) - len(periods) == session.skipped
    assert all(start >= due for start, due in zip(session.step_times, session.step_due, strict=True))
    _check_replay(failed, tmp_path)


def test_so101_session_records_and_replays(tmp_path: Path) -> None:
    build = ArmBuild.so101(seed=5)
    lower = [-1.8, -1.6, -1.6, -1.6, -2.7, -0.15]
    upper = [1.8, 1.6, 1.6, 1.6, 2.7, 1.7]
    clock = ManualClock()
    with build.bus(so101_calibration_scripts([0.0] * 6, lower, upper), clock) as emu:
        bus = ServoBus("feetech", emu.port, so101_motors())
        cal = calibrate_so101(bus, clock)
        bus.close()
    path = tmp_path / "so101.json"
    cal.save(path)
    scripts = [JointScript([0, 0.2, 1.2], [0.0, 0.0, a]) for a in (0.3, -0.2, 0.2, 0.3, 0.5, 0.0)]
    out = tmp_path / "jar_so101"
    session = run_scripted_session("so101", build, path.read_text(), scripts, out, stop_at=25)
    failed = out.with_name("jar_so101_failed")
    assert session.stored == [(False, 0)]
    assert validate_dataset(failed).ok
    _check_replay(failed, tmp_path)


def test_episode_without_keep_failed_is_dropped(gello_cal: GelloCalibration, tmp_path: Path) -> None:
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript.constant(0.0)]
    cal_file = tmp_path / "gello.json"
    gello_cal.save(cal_file)
    out = tmp_path / "jar_teleop"
    session = run_scripted_session("gello", GELLO_BUILD, cal_file.read_text(), scripts, out, stop_at=5,
                                   keep_failed=False)
    assert session.stored == []
    assert not out.with_name("jar_teleop_failed").exists()
    assert validate_dataset(out).episodes == 0


def _planner_demo(family: str = "jar", task: int = 0) -> np.ndarray:
    """The commanded joints + gripper of a kept planner demonstration of a task (no rendering)."""
    from mgdata.engine.executor import Executor
    from mgdata.engine.init_gate import base_task
    from mgdata.grasps.db import GraspDB
    from mgdata.paths import grasps_dir
    from mgdata.record.episode import MemorySink
    from mgdata.tasks.recipe import load_recipe

    recipe = load_recipe(family)
    ex = Executor(base_task(recipe, task), recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)
    sink = MemorySink()
    try:
        result = ex.run(0, sink)
    finally:
        ex.close()
    assert result.kept, f"the planner's demonstration failed: {result.stage} {result.reason}"
    frames, _meta = sink.episodes[0]
    return np.stack([f.action for f in frames[:-1]]).astype(np.float64)


@pytest.mark.slow
def test_gello_replays_a_demonstration_that_the_gate_keeps(gello_cal: GelloCalibration,
                                                           tmp_path: Path) -> None:
    """A person's hand motion, scripted: the GELLO's joints follow a planner demonstration of jar task 0
    (lid closed, jar carried into the goal) on the session's clock, the trigger squeezed while the gripper is
    commanded closed. The session records it through the same monitor and gate, which keep it."""
    actions = _planner_demo()
    t = np.arange(len(actions)) * 0.05
    scripts = [JointScript(t, actions[:, k]) for k in range(7)]
    # the trigger jumps between released and squeezed where the gripper command changes
    knots_t, knots_a = [0.0], [0.6 * actions[0, 7]]
    for j in range(1, len(actions)):
        if actions[j, 7] != actions[j - 1, 7]:
            knots_t += [t[j] - 1e-6, t[j]]
            knots_a += [0.6 * actions[j - 1, 7], 0.6 * actions[j, 7]]
    scripts.append(JointScript([*knots_t, t[-1]], [*knots_a, 0.6 * actions[-1, 7]]))
    cal_file = tmp_path / "gello.json"
    gello_cal.save(cal_file)
    out = tmp_path / "jar_teleop"
    session = run_scripted_session("gello", GELLO_BUILD, cal_file.read_text(), scripts, out)
    assert session.stored == [(True, 0)], session.status.message
    meta = DatasetReader(out).record(0).meta
    assert meta.kept and meta.success and meta.source == "gello" and not any(
        v is not None for v in meta.t_violation.values())
    report = validate_dataset(out)
    assert report.ok, report.problems
    replayed = tmp_path / "replayed"
    replay_episode(out, 0, replayed)
    assert _files(replayed) == _files(out)


@pytest.mark.slow
def test_so101_top_grasp_demonstration_is_kept(tmp_path: Path) -> None:
    """A person's hand on the 5-joint SO-101, scripted: clutter_dry task 0 (pick the cup out of the clutter
    with a top grasp, carry it into the goal). The leader's gripper points down, so its wrist_roll gives the
    grasp's yaw, and one clutch stroke (out, leader back up, in) covers the Panda's 28 cm of height with the
    leader's 5 cm. The same monitor and gate keep the episode; it validates and replays byte for byte."""
    build = ArmBuild.so101(seed=5)
    upper = [1.9, 1.75, 1.7, 1.66, 2.74, 1.7]
    lower = [-u for u in upper[:5]] + [-0.15]
    clock = ManualClock()
    with build.bus(so101_calibration_scripts([0.0] * 6, lower, upper), clock) as emu:
        bus = ServoBus("feetech", emu.port, so101_motors())
        cal = calibrate_so101(bus, clock, scale=2.5)
        bus.close()
    path = tmp_path / "so101.json"
    cal.save(path)
    op = operator_script(_planner_demo("clutter_dry", 0), HOME_Q, cal.scale)
    assert op.strokes >= 1  # the leader's vertical travel alone does not cover the task
    t = np.arange(len(op.arm)) * 0.05
    scripts = [JointScript(t, op.arm[:, k]) for k in range(5)] + [JointScript(t, op.jaw)]
    out = tmp_path / "cup_so101"
    session = run_scripted_session("so101", build, path.read_text(), scripts, out, family="clutter_dry",
                                   presses=op.presses)
    assert session.stored == [(True, 0)], session.status.message
    assert session.mapper.retarget.ik_failures == 0  # type: ignore[attr-defined]
    meta = DatasetReader(out).record(0).meta
    assert meta.kept and meta.success and meta.source == "so101" and not any(
        v is not None for v in meta.t_violation.values())
    stream = LeaderStream.load(stream_path(out, 0))
    assert int(stream.clutch.sum()) == 2 + 2 * op.strokes
    report = validate_dataset(out)
    assert report.ok, report.problems
    replayed = tmp_path / "replayed"
    replay_episode(out, 0, replayed)
    assert _files(replayed) == _files(out)
