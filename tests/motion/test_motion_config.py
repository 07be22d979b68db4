"""recipes/motion.toml → MotionConfig: defaults, and one clear RecipeError per mistake."""

from __future__ import annotations

from pathlib import Path

import pytest

from mgdata.errors import RecipeError
from mgdata.motion import MotionConfig, load_motion_config
from mgdata.paths import recipes_dir


def test_shipped_file_matches_the_documented_defaults() -> None:
    assert (recipes_dir() / "motion.toml").is_file()
    assert load_motion_config() == MotionConfig()


def test_partial_file_keeps_defaults(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text("[retime]\nspeed_scale = 0.25\n[check]\nmargin = 0\n")
    config = load_motion_config(path)
    assert config.retime.speed_scale == 0.25 and config.check.margin == 0.0
    assert isinstance(config.check.margin, float)
    assert config.retime.rate == MotionConfig().retime.rate and config.ik == MotionConfig().ik


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[planer]\nrange = 1.0\n", r"unknown table \[planer\].*'planner'"),
        ("[ik]\nrestart = 3\n", r"unknown key \[ik\] restart; expected one of .*'restarts'"),
        ("[check]\nmargin = \"1cm\"\n", r"\[check\] margin = '1cm': expected a number"),
        ("[ik]\nrestarts = 2.5\n", r"\[ik\] restarts = 2.5: expected an integer"),
        ("[planner]\nsmooth = 1\n", r"\[planner\] smooth = 1: expected true or false"),
        ("[linear]\nspeed = -0.1\n", r"\[linear\] speed = -0.1 must be positive"),
        ("[retime]\nspeed_scale = 0\n", r"\[retime\] speed_scale = 0.0 must be positive"),
        ("[check]\nmargin = -0.01\n", r"\[check\] margin = -0.01 must not be negative"),
        ("[retime]\nrate = 0\n", r"\[retime\] rate = 0.0 must be positive"),
        ("ik = 3\n", r"\[ik\] must be a table"),
        ("[ik]\nsolver = \"cplex\"\n", r"\[ik\] solver = 'cplex' is not an installed QP solver.*daqp"),
        ("[ik\n", "not valid TOML"),
    ],
)
def test_bad_file_names_key_and_expectation(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "motion.toml"
    path.write_text(text)
    with pytest.raises(RecipeError, match=message) as info:
        load_motion_config(path)
    assert str(path) in str(info.value)


def test_missing_explicit_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(RecipeError, match="does not exist"):
        load_motion_config(tmp_path / "nope.toml")
