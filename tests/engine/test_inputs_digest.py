"""A dataset can only be resumed with the inputs it was generated from: recipe, spec, sim, motion, grasps."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mgdata.engine.executor import control_rate
from mgdata.engine.inputs import inputs_digest
from mgdata.errors import RecipeError
from mgdata.motion import load_motion_config
from mgdata.paths import grasps_dir, recipes_dir
from mgdata.sim.config import load_sim_config
from mgdata.tasks.recipe import load_recipe


@pytest.fixture
def project_copy(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(recipes_dir(), tmp_path / "recipes")
    shutil.copytree(grasps_dir(), tmp_path / "grasps")
    monkeypatch.setenv("MGDATA_ROOT", str(tmp_path))
    return tmp_path


@pytest.mark.parametrize("edited", ["recipes/sim.toml", "recipes/motion.toml", "grasps/jar.json",
                                    "recipes/jar.toml", "recipes/specs/jar.toml"])
def test_any_input_file_changes_the_digest(project_copy: Path, edited: str) -> None:
    before = inputs_digest(load_recipe("jar"), project_copy / "grasps")
    path = project_copy / edited
    path.write_text(path.read_text() + "\n")
    assert inputs_digest(load_recipe("jar"), project_copy / "grasps") != before


def test_control_rate_is_sims_and_must_match_the_planner(project_copy: Path) -> None:
    assert control_rate(load_sim_config().physics, load_motion_config()) == 20
    motion = project_copy / "recipes/motion.toml"
    motion.write_text(motion.read_text().replace("rate = 20.0", "rate = 30.0"))
    with pytest.raises(RecipeError, match=r"motion.toml \[retime\] rate = 30.0 Hz does not match"):
        control_rate(load_sim_config().physics, load_motion_config())
