"""The recorder on a real jar scene: frames, monitor consistency, engagement-gated verdict, sink use."""

from __future__ import annotations

import numpy as np
import pytest

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)
from mgdata.errors import MgdataError
from mgdata.ltl import Monitor
from mgdata.record.episode import MemorySink
from mgdata.record.recorder import Recorder, schema_for
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.labelling import Labeller
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import Scene, build_scene
from tests.helpers.sim_tasks import ik, jar_task

DOWN = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(jar_task())


def poke_then_tip(scene: Scene, rec: Recorder, *, touch: bool) -> list[np.ndarray]:
    """Lower the closed fingers onto the jar rim (if ``touch``), raise them, then knock the jar over."""
    ctl = JointController(scene)
    jar = scene.object_body("jar")
    height = scene.objects["jar"].geometry["height"]
    rim_x = 0.5 + scene.objects["jar"].geometry["outer_radius"] - 0.004
    z_end = height - 0.01 if touch else height + 0.12
    q = robot.HOME_Q
    actions = []
    for t in range(40):
        if t < 26:
            z = float(np.interp(t, [0, 19, 25], [height + 0.15, z_end, height + 0.15]))
            q = ik(q, (rim_x, 0.0, z), DOWN)
        scene.data.xfrc_applied[jar, 3:] = [0.3, 0.0, 0.0] if 28 <= t < 31 else [0.0, 0.0, 0.0]
        action = np.array([*q, 1.0], dtype=np.float32)
        ctl.apply(action)
        ctl.step()
        rec.record(action)
        actions.append(action)
    scene.data.xfrc_applied[jar] = 0.0
    return actions


@pytest.mark.parametrize("touch", [True, False])
def test_recorded_episode_is_consistent(scene: Scene, touch: bool) -> None:
    scene.reset()
    sink = MemorySink()
    spec = scene.task.safety
    with CameraRig(scene, cameras=("front", "wrist"), size=64) as rig:
        rec = Recorder(scene, spec, sink, cameras=rig,
                       success_fn=lambda s: s.articulation_fraction("jar") <= 0.05)
        first_state = np.array([*scene.arm_q(), scene.gripper_opening()], dtype=np.float32)
        rec.start()
        actions = poke_then_tip(scene, rec, touch=touch)
        meta = rec.finish(seed=7, draw_index=3, kept=False)
    frames, stored = sink.episodes[-1]
    assert stored is meta and len(frames) == len(actions) + 1 == rec.n_frames
    assert np.array_equal(frames[0].state, first_state)
    assert all(np.array_equal(f.action, a) for f, a in zip(frames, actions, strict=False))
    assert np.array_equal(frames[-1].action, actions[-1])
    f0 = frames[0]
    assert f0.state.dtype == np.float32 and f0.action.dtype == np.float32 and f0.labels.dtype == bool
    assert f0.dfa_state.dtype == np.int16 and f0.violated.shape == (len(spec.constraints),)
    assert set(f0.images) == {"front", "wrist"} and f0.images["front"].shape == (64, 64, 3)
    # The monitor columns equal an offline replay of the recorded labels.
    labels = np.array([f.labels for f in frames])
    states, violated = Monitor.run(spec, labels)
    assert np.array_equal(states, np.array([f.dfa_state for f in frames]))
    assert np.array_equal(violated, np.array([f.violated for f in frames]))
    # The jar was knocked over: upright violated, and the verdict depends on who touched it first.
    names = spec.proposition_names
    upright = labels[:, names.index("jar_upright")]
    assert upright[0] and not upright[-1]
    t_tip = int(np.argmin(upright))
    assert meta.t_violation["stays_upright"] == t_tip and meta.t_violation["never_dropped"] is None
    engaged = [f.engaged for f in frames]
    if touch:
        assert meta.t_engage is not None and meta.t_engage < t_tip
        assert engaged == [t >= meta.t_engage for t in range(len(frames))]
        assert meta.verdict is False
    else:
        assert meta.t_engage is None and not any(engaged) and meta.verdict is True
    assert (meta.family, meta.seed, meta.draw_index, meta.kept, meta.success) == ("jar", 7, 3, False, False)
    assert meta.formulas == {c.id: c.formula for c in spec.constraints}
    assert schema_for(scene, spec, None).propositions == names


def test_labels_match_the_labeller_and_discard_leaves_the_sink_unchanged(scene: Scene) -> None:
    scene.reset()
    sink = MemorySink()
    rec = Recorder(scene, scene.task.safety, sink)
    rec.start()
    ctl = JointController(scene)
    action = np.array([*robot.HOME_Q, 0.0], dtype=np.float32)
    for _ in range(3):
        ctl.apply(action)
        ctl.step()
        rec.record(action)
    assert np.array_equal(rec._pending.labels, Labeller(scene, scene.task.safety).labels())
    assert rec.n_frames == 3 and rec.t == 3
    rec.discard()
    assert sink.episodes == [] and sink._frames == []


def test_misuse_is_a_clear_error(scene: Scene) -> None:
    rec = Recorder(scene, scene.task.safety, MemorySink())
    with pytest.raises(MgdataError, match="before start"):
        rec.record(np.zeros(8))
    rec.start()
    with pytest.raises(MgdataError, match="in progress"):
        rec.start()
    with pytest.raises(MgdataError, match="shape"):
        rec.record(np.zeros(7))
