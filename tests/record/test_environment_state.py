"""``observation.environment_state``: derived from the stored physics states (``mgdata export
--format state``), checked against values recomputed here with raw MuJoCo from the qpos of the objects'
joints."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco  # after mgdata (conftest imports it first: it sets MUJOCO_GL)
import numpy as np
import pyarrow.parquet as pq
import pytest

from mgdata.record.export import export_dataset
from mgdata.record.physics import model_from_bytes
from mgdata.record.reader import DatasetReader
from mgdata.record.recorder import Recorder, schema_for
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.scene import build_scene
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe

STEPS = 12
FEATURE = "observation.environment_state"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two recorded jar episodes (tasks 0 and 1, no cameras) in which the arm sways and the lid settles."""
    root = tmp_path_factory.mktemp("envstate") / "ds"
    writer = None
    for k, task_id in enumerate((0, 1)):
        scene = build_scene(draw_task(load_recipe("jar"), task_id))
        spec = scene.task.safety
        writer = writer or DatasetWriter.create(root, schema_for(scene, spec, None), spec=spec)
        scene.reset()
        ctl, rec = JointController(scene), Recorder(scene, spec, writer)
        rec.start()
        for t in range(STEPS):
            action = np.array([*(robot.HOME_Q + 0.2 * np.sin(t / 3.0)), float(t > STEPS // 2)], np.float32)
            ctl.apply(action)
            ctl.step()
            rec.record(action)
        rec.finish(seed=k, draw_index=k, kept=False)
    assert writer is not None
    writer.close()
    return root


def _raw_expected(model: mujoco.MjModel, state: np.ndarray, spec: int) -> tuple[list[str], np.ndarray]:
    """The documented layout from qpos alone: jar pose, food pose (base frame), the jar's hinge, goal."""
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, spec)
    base_pos = model.body_pos[model.body("base").id]
    base_quat = model.body_quat[model.body("base").id]
    base_rot = np.empty(9)
    mujoco.mju_quat2Mat(base_rot, base_quat)
    base_rot = base_rot.reshape(3, 3)
    inv = np.empty(4)
    mujoco.mju_negQuat(inv, base_quat)
    names: list[str] = []
    values: list[float] = []
    for inst in ("jar", "food"):
        adr = model.jnt_qposadr[model.joint(f"{inst}/free").id]
        pos, quat = data.qpos[adr:adr + 3], data.qpos[adr + 3:adr + 7]
        q = np.empty(4)
        mujoco.mju_mulQuat(q, inv, quat)
        q = q / np.linalg.norm(q)
        q = -q if q[0] < 0 else q
        names += [f"{inst}.pos.{a}" for a in "xyz"] + [f"{inst}.quat.{a}" for a in "wxyz"]
        values += [*(base_rot.T @ (pos - base_pos)), *q]
        for j in range(model.njnt):
            jname = model.joint(j).name
            if jname.startswith(f"{inst}/") and int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE):
                names.append(f"{inst}.{jname[len(inst) + 1:]}")
                values.append(data.qpos[model.jnt_qposadr[j]])
    goal = model.body("goal").id
    names += ["goal.x", "goal.y", "goal.z", "goal.radius"]
    values += [*(base_rot.T @ (model.body_pos[goal] - base_pos)), model.geom_size[model.geom("goal").id, 0]]
    return names, np.asarray(values, np.float32)


def test_state_export_matches_raw_mujoco(recorded: Path, tmp_path: Path) -> None:
    out = export_dataset(recorded, tmp_path / "state", "state")
    source = DatasetReader(recorded)
    info = json.loads((out / "meta/info.json").read_text())
    feature = info["features"][FEATURE]
    assert not [k for k, f in info["features"].items() if f["dtype"] == "video"]
    assert "sim.physics_state" not in info["features"] and not (out / "videos").exists()
    # no per-frame labels, DFA states or violation flags (no policy reads them; LeRobot converts every
    # column of every action chunk); engagement and success stay, and the view validates
    assert not {"safety.labels", "safety.dfa_state", "safety.violated"} & set(info["features"])
    assert {"safety.engaged", "safety.success"} <= set(info["features"])
    report = validate_dataset(out)
    assert report.ok, report.problems
    table = pq.read_table(out / "data/chunk-000/file-000.parquet")
    env = np.stack(table.column(FEATURE).to_numpy(zero_copy_only=False))
    assert env.dtype == np.float32 and env.shape == (table.num_rows, feature["shape"][0])
    row = 0
    for e in range(source.num_episodes):
        ep = source.episode(e)
        model = model_from_bytes(source.scene_mjb(e))
        for t in range(ep.length):
            names, expected = _raw_expected(model, ep.physics_state[t], int(source.physics_spec))
            assert feature["names"] == names
            np.testing.assert_allclose(env[row], expected, rtol=0, atol=2e-6,
                                       err_msg=f"episode {e} frame {t}")
            row += 1
    assert row == table.num_rows
    stats = json.loads((out / "meta/stats.json").read_text())[FEATURE]
    np.testing.assert_allclose(stats["mean"], env.astype(np.float64).mean(axis=0), atol=1e-9)
    np.testing.assert_allclose(stats["min"], env.min(axis=0), atol=0)
    assert stats["count"] == [table.num_rows]
    episodes = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet")
    assert f"stats/{FEATURE}/mean" in episodes.column_names
    assert not [c for c in episodes.column_names if c.startswith("videos/")]


def test_add_environment_state_needs_physics(recorded: Path, tmp_path: Path) -> None:
    """The feature is derived from the physics states: a view without them (pi0, v2.1) is refused."""
    from mgdata.errors import DatasetError

    with pytest.raises(DatasetError, match=r"v3\.0"):
        export_dataset(recorded, tmp_path / "x", "v2.1", add_environment_state=True)


def test_a_recipe_without_cameras_makes_a_camera_free_schema(tmp_path: Path) -> None:
    """``cameras = []`` in a recipe: a state-only dataset (no image size, no rendering)."""
    import shutil

    from mgdata.engine.executor import dataset_schema
    from mgdata.paths import recipes_dir

    shutil.copytree(recipes_dir() / "specs", tmp_path / "specs")
    text = (recipes_dir() / "jar.toml").read_text()
    five = 'cameras = ["front", "left", "right", "shoulder", "wrist"]'
    (tmp_path / "jar.toml").write_text(text.replace(five, "cameras = []"))
    recipe = load_recipe(tmp_path / "jar.toml")
    assert recipe.tasks.cameras == ()
    schema = dataset_schema(recipe)
    assert schema.cameras == () and schema.image_height == schema.image_width == 0
