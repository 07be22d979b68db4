"""Restarts (issue 43): a jar demonstration started from a mid-task state of another demonstration.

The restart states come from a plain demonstration's recorded physics states, and every check is made from
raw MuJoCo (the lid hinge's qpos, ``data.contact``, body poses), not with the restart code.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task, cached_grasp_db
from mgdata.paths import grasps_dir
from mgdata.record.episode import MemorySink
from mgdata.record.physics import physics_state, set_physics_state
from mgdata.skeleton.skeleton import load_family_recipe
from tests.helpers.rawdata import hand_touches


@pytest.fixture(scope="module")
def jar():  # type: ignore[no-untyped-def]
    recipe = load_family_recipe("jar")
    ex = Executor(base_task(recipe, 0), recipe, grasps=cached_grasp_db(grasps_dir()), render=False)
    sink = MemorySink()
    assert ex.run(0, sink).kept
    states = np.stack([f.physics_state for f in sink.episodes[0][0]])
    yield ex, states
    ex.close()


def _raw(ex: Executor, state: np.ndarray) -> tuple[float, set[str]]:
    """The lid hinge's angle (rad, raw qpos) and the bodies the hand's geoms touch, in ``state``."""
    m, d = ex.scene.model, ex.scene.data
    set_physics_state(m, d, state)
    touched = {m.body(b).name for b in hand_touches(m, d)}
    return float(d.qpos[m.jnt_qposadr[m.joint("jar/lid_hinge").id]]), touched


def test_a_restart_with_the_lid_shut_runs_only_the_carry_and_is_kept(jar) -> None:  # type: ignore[no-untyped-def]
    ex, states = jar
    raw = [_raw(ex, s) for s in states]
    closed = abs(raw[-1][0])  # the hinge at the demo's end: shut
    pushed = [i for i, (_, t) in enumerate(raw) if "jar/lid" in t]
    assert pushed, "the plain demo's fingers push the lid"
    # a resting mid-task state: lid shut (as at the end), the hand touching nothing, before the grasp
    k = next(i for i, (a, t) in enumerate(raw) if i > pushed[-1] + 20 and abs(abs(a) - closed) < 1e-3
             and not t)
    sink = MemorySink()
    result = ex.run(3, sink, start=states[k], origin={"parent": "demo", "step": k}, source="correction")
    assert result.kept, (result.stage, result.reason)
    frames, meta = sink.episodes[0]
    assert meta.source == "correction"
    assert meta.variation["restart"] == {"parent": "demo", "step": k, "phases": ["carry"]}
    assert np.array_equal(frames[0].physics_state, states[k])  # it starts exactly there
    after = [_raw(ex, f.physics_state) for f in frames]
    assert not any("jar/lid" in t for _, t in after), "no lid push: the fingers never touch the lid"
    assert max(abs(abs(a) - closed) for a, _ in after) < 0.05  # the lid stays shut throughout
    assert any("jar" in t for _, t in after)  # the carry grasps the jar
    m, d = ex.scene.model, ex.scene.data
    set_physics_state(m, d, frames[-1].physics_state)
    goal = np.asarray(ex.task.goal.pos)
    assert np.linalg.norm(d.xipos[m.body("jar").id] - goal) < ex.task.goal.radius + 0.03  # carried there


def test_a_restart_before_the_push_runs_both_phases(jar) -> None:  # type: ignore[no-untyped-def]
    ex, states = jar
    sink = MemorySink()
    results = [ex.run(draw, sink, start=states[20], origin={"step": 20}, source="correction")
               for draw in (1, 2)]  # the lid still open, the fingers not yet at it
    assert sink.episodes, [(r.stage, r.reason) for r in results]
    assert sink.episodes[0][1].variation["restart"]["phases"] == ["close_lid", "carry"]
    assert any("jar/lid" in _raw(ex, f.physics_state)[1] for f in sink.episodes[0][0])


def test_states_a_task_cannot_restart_from_are_refused_with_their_rule(jar) -> None:  # type: ignore[no-untyped-def]
    ex, states = jar
    raw = [_raw(ex, s) for s in states]
    touching = next(i for i, (_, t) in enumerate(raw) if t)
    m, d = ex.scene.model, ex.scene.data
    jar_dof = m.jnt_dofadr[m.joint("jar/free").id]
    jar_qpos = m.jnt_qposadr[m.joint("jar/free").id]
    set_physics_state(m, d, states[5])
    d.qvel[jar_dof:jar_dof + 3] = [0.2, 0.0, 0.0]  # the jar sliding at 20 cm/s
    moving = physics_state(m, d)
    set_physics_state(m, d, states[5])
    d.qpos[jar_qpos + 3:jar_qpos + 7] = [np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0]  # on its side
    mujoco.mj_forward(m, d)
    tipped = physics_state(m, d)
    for state, rule in ((states[touching], "restart.holding"), (moving, "restart.at_rest"),
                        (tipped, "restart.safe")):
        result = ex.run(0, MemorySink(), start=state, keep_failed=False)
        assert not result.kept and result.stage == "restart_refused", (rule, result.stage, result.reason)
        assert result.reason is not None and result.reason.startswith(rule), (rule, result.reason)
        assert result.steps == 0
