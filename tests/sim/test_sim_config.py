"""recipes/sim.toml: the shipped values are the code defaults; bad values are one clear error."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.errors import RecipeError
from mgdata.grasps.config import load_grasp_config
from mgdata.paths import recipes_dir
from mgdata.sim import robot
from mgdata.sim.assets import get_model
from mgdata.sim.cameras import CameraLayout
from mgdata.sim.config import SimConfig, load_sim_config, sim_config_from_dict
from mgdata.sim.controller import JointController
from mgdata.sim.physics_config import Physics
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.tasks.recipe import load_recipe
from tests.helpers.sim_tasks import jar_task, task_with


def _finger_geoms(model: mujoco.MjModel) -> np.ndarray:
    bodies = [model.body(b).id for b in robot.FINGER_BODIES]
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.flatnonzero(np.isin(model.geom_bodyid, bodies) & colliding)


def test_shipped_file_lists_every_key_with_the_code_default() -> None:
    path = recipes_dir() / "sim.toml"
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    for section in dataclasses.fields(SimConfig):
        names = {f.name for f in dataclasses.fields(section.default_factory())}  # type: ignore[misc]
        assert set(raw[section.name]) == names, section.name
    assert load_sim_config(path) == SimConfig()


def test_every_scene_has_the_grip_contact_model(jar_scene: Scene) -> None:
    m = jar_scene.model
    fingers = _finger_geoms(m)
    assert len(fingers) == 12  # finger mesh + 5 pads, per finger
    assert (m.geom_condim[fingers] == 4).all()
    assert np.allclose(m.geom_friction[fingers, 1], 0.02)
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    others = np.setdiff1d(robot.robot_geom_ids(m), fingers)
    assert (m.geom_condim[others] == 3).all()  # only the pads change


@pytest.mark.parametrize(("text", "message"), [
    ("[physics]\ntimestep = 0.002\nsubsteps = 25\n", r"unknown key \[physics\] substeps; expected one of"),
    ("[physic]\ntimestep = 0.002\n", r"unknown table \[physic\]"),
    ('[physics]\ntimestep = "2ms"\n', r"\[physics\] timestep = '2ms': expected a number"),
    ("[physics]\niterations = 10.5\n", r"\[physics\] iterations = 10.5: expected an integer"),
    ("[gripper]\nfinger_condim = true\n", r"\[gripper\] finger_condim = True: expected an integer"),
    ("[cameras]\nfront = [1.0, 0.0]\n", r"\[cameras\] front = \[1.0, 0.0\]: expected a list of 3 numbers"),
    ("[physics]\ncontrol_dt = 0.051\n", r"\[physics\] control_dt = 0.051: expected a whole number of"),
    ('[physics]\nsolver = "newton"\n', r"\[physics\] solver = 'newton': expected one of \['CG', 'Newton'"),
    ("[gripper]\nfinger_condim = 5\n", r"\[gripper\] finger_condim = 5: expected 3, 4 or 6"),
    ("[gripper]\nclosed_ctrl = -3.5\n", r"\[gripper\] closed_ctrl = -3.5: expected a value in ctrl_range"),
    ("[gripper]\nfinger_solimp = [0.99, 0.9, 0.001]\n",
     r"\[gripper\] finger_solimp = \[0.99, 0.9, 0.001\]: expected"),
    ("[gripper]\npeak_force = 0.0\n", r"\[gripper\] peak_force = 0.0: expected a number > 0"),
    ("[cameras]\nleft = [0.45, 0.0, 1.5]\n", r"\[cameras\] left = .*straight above or below look_at"),
    ("[cameras]\nimage_size = 4\n", r"\[cameras\] image_size = 4: expected an integer >= 8"),
    ("physics = 3\n", r"\[physics\] must be a table"),
    ("[physics\n", r"not valid TOML"),
])
def test_bad_values_are_one_error_naming_file_and_key(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "sim.toml"
    path.write_text(text)
    with pytest.raises(RecipeError, match=message) as err:
        load_sim_config(path)
    assert str(path) in str(err.value)


def test_missing_explicit_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(RecipeError, match="does not exist"):
        load_sim_config(tmp_path / "nope.toml")


def test_settings_take_effect_in_the_scene() -> None:
    sim = sim_config_from_dict({
        "physics": {"timestep": 0.001, "cone": "pyramidal", "iterations": 50},
        "gripper": {"finger_condim": 3, "finger_torsional_friction": 0.01, "damping": 80,
                    "closed_ctrl": -0.5, "peak_force": 100.0, "finger_solimp": [0.9, 0.95, 0.002]},
        "cameras": {"fovy": 45, "front": [1.5, 0.1, 0.8]},
    })
    scene = build_scene(jar_task(), sim=sim)
    m = scene.model
    assert m.opt.timestep == 0.001 and scene.physics.substeps == 50
    assert m.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL and m.opt.iterations == 50
    fingers = _finger_geoms(m)
    assert (m.geom_condim[fingers] == 3).all() and np.allclose(m.geom_friction[fingers, 1], 0.01)
    grip = m.actuator(robot.GRIPPER_ACTUATOR).id
    assert m.actuator_biasprm[grip, 2] == -80.0
    assert np.allclose(m.actuator_forcerange[grip], [-200.0, 200.0])
    assert np.allclose(m.geom_solimp[fingers, :3], [0.9, 0.95, 0.002])
    assert m.cam_fovy[m.camera("front").id] == 45.0 and m.cam_fovy[m.camera("wrist").id] == 75.0
    assert np.allclose(m.cam_pos[m.camera("front").id], [1.5, 0.1, 0.8])
    ctl = JointController(scene)
    ctl.apply(np.array([*robot.HOME_Q, 1.0]))
    assert scene.data.ctrl[grip] == -0.5


def test_liquid_scenes_use_the_liquid_solver() -> None:
    sim = SimConfig(physics=Physics(liquid_solver="PGS", liquid_iterations=12))
    bowl = get_model("bowl/round_03")
    water = ObjectPlacement("water", "liquid/water_01", (0.5, -0.2, bowl.geometry["bottom"]))
    scene = build_scene(task_with(ObjectPlacement("bowl", bowl.name, (0.5, -0.2, 0.0)), water), sim=sim)
    assert scene.model.opt.solver == mujoco.mjtSolver.mjSOL_PGS and scene.model.opt.iterations == 12
    dry = build_scene(jar_task(), sim=sim)
    assert dry.model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON and dry.model.opt.iterations == 100


def test_default_image_size_comes_from_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "root"
    (root / "recipes" / "specs").mkdir(parents=True)
    (root / "recipes" / "sim.toml").write_text("[cameras]\nimage_size = 96\n")
    jar = (recipes_dir() / "jar.toml").read_text().replace("image_size = 256\n", "")
    (root / "recipes" / "jar.toml").write_text(jar)
    for spec in (recipes_dir() / "specs").iterdir():
        (root / "recipes" / "specs" / spec.name).write_text(spec.read_text())
    monkeypatch.setenv("MGDATA_ROOT", str(root))
    assert load_recipe("jar").tasks.image_size == 96
    assert jar_task().image_size == 96
    assert CameraLayout().image_size == 256


def test_a_stale_grip_section_in_grasps_toml_names_its_new_home(tmp_path: Path) -> None:
    path = tmp_path / "grasps.toml"
    path.write_text("[grip]\ncondim = 4\n")
    with pytest.raises(RecipeError, match=r"\[grip\].*recipes/sim.toml"):
        load_grasp_config(path)
