"""EpisodeRunner: controller → recorder → gate, checked against quantities computed here from raw MuJoCo
data."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.episode.gate import SuccessGate
from mgdata.episode.runner import EpisodeRunner
from mgdata.record.episode import MemorySink
from mgdata.record.recorder import Recorder
from mgdata.sim.controller import JointController
from mgdata.sim.robot import HOME_Q, arm_qpos_adr
from mgdata.sim.scene import Scene, build_scene
from mgdata.tasks.recipe import load_recipe


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(base_task(load_recipe("jar"), 0))


def _runner(scene: Scene, success: bool, hold: int = 3, horizon: int = 6) -> tuple[EpisodeRunner, MemorySink]:
    scene.reset()
    sink = MemorySink()
    rec = Recorder(scene, scene.task.safety, sink, None, lambda _s: success)
    return EpisodeRunner(JointController(scene), rec, SuccessGate(hold), horizon), sink


def test_frames_hold_the_measured_state_and_the_horizon_ends_it(scene: Scene) -> None:
    runner, sink = _runner(scene, success=False)
    runner.start()
    measured = [scene.data.qpos[arm_qpos_adr(scene.model)].copy()]
    ends = []
    for k in range(6):
        q = HOME_Q + 0.02 * (k + 1)
        ends.append(runner.step(q, 0.0, holding=False).end)
        measured.append(scene.data.qpos[arm_qpos_adr(scene.model)].copy())
    assert ends == [None] * 5 + ["timeout"]
    meta = runner.finish(seed=0, draw_index=0, source="gello", stage="timeout", reason="horizon")
    frames = sink.episodes[0][0]
    assert len(frames) == 7 and not meta.kept and meta.failure_stage == "timeout" and meta.source == "gello"
    for frame, q in zip(frames, measured, strict=True):
        assert np.allclose(frame.state[:7], q, atol=1e-6)
    assert np.allclose(frames[2].action[:7], HOME_Q + 0.06, atol=1e-6)  # frame t: the action taken at t


def test_gate_passes_after_the_hold_window(scene: Scene) -> None:
    runner, _ = _runner(scene, success=True, hold=3)
    runner.start()
    moving = [runner.step(HOME_Q, 0.0, holding=False).end for _ in range(2)]  # success while moving: no count
    ends = [runner.step(HOME_Q, 0.0, holding=True).end for _ in range(3)]
    assert moving == [None, None] and ends == [None, None, "passed"] and runner.kept
    assert runner.finish(seed=0, draw_index=0, source="gello").kept


def test_tipping_the_jar_is_unsafe_at_that_step(scene: Scene) -> None:
    """Tip the jar 60° by hand between two steps; the runner must report the violation of the upright
    constraint at the step where the tilt (computed here from the jar body's rotation) exceeds 30°."""
    runner, _ = _runner(scene, success=False, horizon=50)
    runner.start()
    assert runner.step(HOME_Q, 0.0, holding=True).end is None
    m, d = scene.model, scene.data
    body = scene.object_body("jar")
    jnt = m.body_jntadr[body]
    adr = m.jnt_qposadr[jnt]
    assert m.jnt_type[jnt] == mujoco.mjtJoint.mjJNT_FREE
    tilt = np.array([np.cos(np.pi / 6), np.sin(np.pi / 6), 0.0, 0.0])  # 60° about x
    quat = np.empty(4)
    mujoco.mju_mulQuat(quat, tilt, d.qpos[adr + 3:adr + 7].copy())
    d.qpos[adr + 3:adr + 7] = quat
    d.qpos[adr + 2] += 0.02
    mujoco.mj_forward(m, d)
    z = d.xmat[body].reshape(3, 3)[:, 2]
    assert np.degrees(np.arccos(z[2])) > 30.0
    out = runner.step(HOME_Q, 0.0, holding=True)
    assert out.end == "unsafe" and "jar_stays_upright" in (out.reason or "")
    assert runner.recorder.first_violation["jar_stays_upright"] == 2  # s_2, observed after the 2nd step
