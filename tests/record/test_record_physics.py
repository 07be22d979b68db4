"""Self-contained datasets: the compiled scene and every frame's physics state restore, re-render and
re-simulate a recorded episode bit for bit, using the example code of ``docs/dataset-format.md``."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import mujoco  # after mgdata (conftest imports it first: it sets MUJOCO_GL)
import numpy as np
import pyarrow.parquet as pq
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import sha256_file
from mgdata.record.episode import MemorySink
from mgdata.record.physics import STATE_SPEC, model_bytes, physics_state, set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.record.recorder import Recorder, schema_for
from mgdata.record.scenes import Scenes, write_scenes
from mgdata.record.staging import EpisodeStager
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import Scene, build_scene
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe
from tests.helpers import rawdata
from tests.helpers.rawdata import raw_step
from tests.helpers.repo import REPO

CAMERAS, SIZE, STEPS = ("front", "wrist"), 64, 30
SCENES = layout.scenes_path(layout.FileRef())
"""The first scenes file (these tests' datasets have one)."""


def _scene(task_id: int = 0) -> Scene:
    return build_scene(draw_task(load_recipe("jar"), task_id))


def _actions(k: int) -> list[np.ndarray]:
    """Episode ``k``: the arm sways away from home and back; the gripper closes half-way."""
    offset = np.array([0.3, -0.2, 0.2, -0.3, 0.1, 0.3, -0.4]) * (1 if k == 0 else -0.7)
    return [np.array([*(robot.HOME_Q + offset * np.sin(np.pi * t / STEPS)), float(t >= STEPS // 2)],
                     dtype=np.float32) for t in range(STEPS)]


TASKS = (0, 1, 0)
"""The recorded episodes' jar tasks: the second scene is stored as a delta, the third reuses the first."""


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three real recorded episodes of jar tasks 0, 1, 0 (64² front and wrist cameras)."""
    root = tmp_path_factory.mktemp("physics") / "ds"
    writer = None
    for k, task_id in enumerate(TASKS):
        scene = _scene(task_id)
        ctl = JointController(scene)
        spec = scene.task.safety
        with CameraRig(scene, cameras=CAMERAS, size=SIZE) as rig:
            writer = writer or DatasetWriter.create(root, schema_for(scene, spec, rig), spec=spec)
            scene.reset()
            rec = Recorder(scene, spec, writer, cameras=rig)
            rec.start()
            for action in _actions(k):
                ctl.apply(action)
                ctl.step()
                rec.record(action)
            rec.finish(seed=k, draw_index=k, kept=False)
    writer.close()
    return root


def _doc_example() -> dict:
    """Run the example of ``docs/dataset-format.md`` (the python block after its marker) as written."""
    text = (REPO / "docs/dataset-format.md").read_text()
    code = re.search(r"<!-- example: restore-frame -->\n```python\n(.*?)```", text, re.S)
    assert code, "the restore-frame example is missing from docs/dataset-format.md"
    namespace: dict = {}
    exec(compile(code.group(1), "docs/dataset-format.md", "exec"), namespace)
    return namespace


def _resimulated(task_id: int, actions: np.ndarray, t: int) -> Scene:
    """The checkout's scene after executing ``actions[:t]`` from the task's initial state (the executor's
    controller and physics step)."""
    scene = _scene(task_id)
    scene.reset()
    ctl = JointController(scene)
    for action in actions[:t]:
        ctl.apply(action)
        ctl.step()
    return scene


def test_every_frame_stores_the_state_its_observation_was_taken_from(recorded: Path) -> None:
    reader = DatasetReader(recorded)
    assert reader.physics_spec == STATE_SPEC
    ep = reader.episode(1)
    assert ep.physics_state.dtype == np.float64 and ep.physics_state.shape == (STEPS + 1, 78)
    scene = _scene(ep.meta.task_id)
    scene.reset()
    ctl = JointController(scene)
    for t in range(ep.length):
        assert np.array_equal(physics_state(scene.model, scene.data), ep.physics_state[t]), t
        measured = np.array([*scene.arm_q(), scene.gripper_opening()], dtype=np.float32)
        assert np.array_equal(measured, ep.state[t]), t
        ctl.apply(ep.action[t])
        ctl.step()


def test_stepping_from_frame_t_with_action_t_gives_frame_t_plus_1(recorded: Path) -> None:
    reader = DatasetReader(recorded)
    for e in range(reader.num_episodes):
        ep = reader.episode(e)
        scene = _scene(ep.meta.task_id)
        ctl = JointController(scene)
        for t in range(ep.length - 1):
            set_physics_state(scene.model, scene.data, ep.physics_state[t])
            ctl.apply(ep.action[t])
            ctl.step()
            assert np.array_equal(physics_state(scene.model, scene.data), ep.physics_state[t + 1]), (e, t)


def test_the_stored_scene_alone_resimulates_with_plain_mujoco(recorded: Path) -> None:
    """No mgdata code: the next frame's stored ctrl, ``fps`` and the model's timestep give the step."""
    reader = DatasetReader(recorded)
    model = mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": reader.scene_mjb(1)})
    substeps = round(1.0 / reader.schema.fps / model.opt.timestep)
    ep = reader.episode(1)
    for t in range(ep.length - 1):
        got = raw_step(model, ep.physics_state[t], ep.physics_state[t + 1], substeps)
        assert np.array_equal(got, ep.physics_state[t + 1]), t


def test_doc_example_restores_and_renders_frame_t(recorded: Path) -> None:
    restore_frame = _doc_example()["restore_frame"]
    reader = DatasetReader(recorded)
    e, t = 1, 17
    model, data, rgb = restore_frame(recorded, e, t, camera="front", size=SIZE)
    ep = reader.episode(e)
    state = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    assert np.array_equal(state, ep.physics_state[t])
    live = _resimulated(ep.meta.task_id, ep.action, t)
    assert model_bytes(live.model) == reader.scene_mjb(e)
    for name in ("qpos", "qvel", "xpos", "xquat", "site_xpos", "geom_xpos"):
        assert np.array_equal(getattr(data, name), getattr(live.data, name)), name
    with CameraRig(live, cameras=("front",), size=SIZE) as rig:
        ours = rig.render()["front"]  # mgdata's rig draws coarser shapes and robot meshes (docs/render.md)
    assert np.abs(rgb.astype(int) - ours.astype(int)).mean() < 2.0  # the same picture, within a level or two
    video = reader.frames(e, "front")[t]
    mse = np.mean((video.astype(np.float64) - rgb.astype(np.float64)) ** 2)
    assert 10 * np.log10(255.0**2 / mse) > 28  # and what the (lossy) video holds


def test_one_scene_per_task_delta_coded_and_referenced_from_the_episodes_table(recorded: Path) -> None:
    reader = DatasetReader(recorded)
    ids = [reader.record(e).scene for e in range(3)]
    assert re.fullmatch(r"task_000000_[0-9a-f]{16}", ids[0]) and ids[1].startswith("task_000001_")
    assert ids[2] == ids[0]
    table = pq.read_table(recorded / SCENES)
    rows = [{**row, "data": rawdata.unframed(table.schema, row)} for row in table.to_pylist()]
    assert [(r["scene"], r["base"]) for r in rows] == [(ids[0], None), (ids[1], ids[0])]
    assert sorted(recorded.glob("meta/scenes*")) == [recorded / layout.SCENES_DIR]
    for e, task_id in enumerate(TASKS):
        assert reader.scene_mjb(e) == model_bytes(_scene(task_id).model)
    assert len(rows[1]["data"]) == rows[1]["size"] and rows[0]["size"] > 4_000_000
    # one whole model (with the far level-of-detail robot meshes, docs/render.md) + one small delta
    assert (recorded / SCENES).stat().st_size < 2_600_000 + 100_000
    assert reader.info["mgdata"]["sha256"][SCENES] == sha256_file(recorded / SCENES)
    feature = reader.info["features"][layout.PHYSICS_STATE]
    assert feature["dtype"] == "float64" and feature["shape"] == [78]
    assert feature["info"]["mujoco_state_spec"] == STATE_SPEC
    assert validate_dataset(recorded).ok, validate_dataset(recorded).problems


def test_model_bytes_are_identical_across_processes(recorded: Path) -> None:
    import subprocess
    import sys

    code = ("import mgdata, sys; from mgdata.record.physics import model_bytes; "
            "from mgdata.sim.scene import build_scene; from mgdata.tasks.base import draw_task; "
            "from mgdata.tasks.recipe import load_recipe; "
            "sys.stdout.buffer.write(model_bytes(build_scene(draw_task(load_recipe('jar'), 0)).model))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120, check=True).stdout
    assert out == DatasetReader(recorded).scene_mjb(0)


def test_a_broken_scene_is_reported(recorded: Path, tmp_path: Path) -> None:
    root = shutil.copytree(recorded, tmp_path / "ds")
    path = root / SCENES
    table = pq.read_table(path)
    rows = [{**row, "data": rawdata.unframed(table.schema, row)} for row in table.to_pylist()]
    rows[1]["data"] = rows[1]["data"][:-1] + b"x"  # one byte of the delta-coded scene
    rows.append({**rows[1], "scene": "task_000009_0000000000000000"})
    write_scenes(rows, path)
    info = json.loads((root / layout.INFO_PATH).read_text())
    info["mgdata"]["sha256"][SCENES] = sha256_file(path)  # a consistent forgery
    (root / layout.INFO_PATH).write_text(json.dumps(info))
    problems = validate_dataset(root).problems
    assert problems == [
        f"episode 1: its scene {rows[1]['scene']!r} is not a loadable MuJoCo model ({path}: scene "
        f"{rows[1]['scene']!r} does not decode to its recorded size and SHA-256)",
        f"{path}: scene 'task_000009_0000000000000000' is not used by any episode"]


def test_an_episode_with_physics_states_needs_its_scene(tmp_path: Path) -> None:
    scene = _scene()
    sink = MemorySink()
    rec = Recorder(scene, scene.task.safety, sink)
    rec.start()
    rec.finish(seed=0, draw_index=0, kept=False)
    (frames, meta), mjb = sink.episodes[0], sink.scenes[0]
    assert mjb == model_bytes(scene.model)
    stager = EpisodeStager(tmp_path / "staged", schema_for(scene, scene.task.safety, None))
    for frame in frames:
        stager.add_frame(frame)
    with pytest.raises(DatasetError, match="needs its compiled scene"):
        stager.end_episode(meta)  # a sink that lost the scene


def test_training_views_drop_the_simulator_state_and_v21_keeps_it(recorded: Path, tmp_path: Path) -> None:
    from mgdata.record.export import export_dataset

    smol = export_dataset(recorded, tmp_path / "smol", "smolvla", overview="front")
    report = validate_dataset(smol)
    assert report.ok, report.problems
    view = DatasetReader(smol)
    assert view.schema.physics_state_size == 0 and view.physics_spec is None
    assert not list(smol.glob("meta/scenes*")) and view.episode(0).physics_state is None
    for fmt in ("pi0", "groot"):
        out = export_dataset(recorded, tmp_path / fmt, fmt, overview="front")
        info = json.loads((out / "meta/info.json").read_text())
        assert layout.PHYSICS_STATE not in info["features"] and not list(out.glob("meta/scenes*"))
    v21 = export_dataset(recorded, tmp_path / "v21", "v2.1")
    src = DatasetReader(recorded)
    rows = pq.read_table(v21 / "data/chunk-000/episode_000001.parquet")
    stored = np.stack(rows.column(layout.PHYSICS_STATE).to_pylist())
    assert np.array_equal(stored, src.episode(1).physics_state)
    scene = json.loads((v21 / "meta/mgdata_episodes.jsonl").read_text().splitlines()[1])["scene"]
    assert (v21 / SCENES).read_bytes() == (recorded / SCENES).read_bytes()  # copied as it is
    assert Scenes.read(v21).mjb(scene) == src.scene_mjb(1)


def test_an_executor_attempt_replays_bit_identically_from_its_recorded_states() -> None:
    """The planner executor's own episode (planning, IK and skeleton reads between control steps
    included): every frame's state, stepped with its action, gives the next frame's state."""
    from mgdata.engine.executor import Executor
    from mgdata.grasps.db import GraspDB
    from mgdata.paths import grasps_dir

    recipe = load_recipe("jar")
    ex = Executor(base_task(recipe, 0), recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)
    sink = MemorySink()
    res = ex.run(0, sink, keep_failed=True)
    ex.close()
    (frames, _), mjb = sink.episodes[0], sink.scenes[0]
    assert res.steps > 100 and len(frames) == res.steps + 1
    model = mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb})
    scene = _scene(0)
    assert model_bytes(scene.model) == mjb
    ctl = JointController(scene)
    scene.reset()
    assert np.array_equal(physics_state(scene.model, scene.data), frames[0].physics_state)
    for t in range(len(frames) - 1):
        set_physics_state(scene.model, scene.data, frames[t].physics_state)
        ctl.apply(frames[t].action)
        ctl.step()
        assert np.array_equal(physics_state(scene.model, scene.data), frames[t + 1].physics_state), t
    assert mujoco.mj_stateSize(model, STATE_SPEC) == len(frames[0].physics_state)
