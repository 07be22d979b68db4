"""Recipe loading: the shipped jar recipe, and one clear error per kind of bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from mgdata.errors import RecipeError, SpecError, UnknownFamilyError
from mgdata.paths import recipes_dir
from mgdata.tasks.base import base_task
from mgdata.tasks.recipe import load_recipe


def _variant(tmp: Path, old: str, new: str) -> Path:
    text = (recipes_dir() / "jar.toml").read_text()
    text = text.replace('spec = "specs/jar.toml"', f'spec = "{recipes_dir() / "specs" / "jar.toml"}"')
    assert old in text, old
    path = tmp / "jar.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_shipped_recipe_loads() -> None:
    r = load_recipe("jar")
    assert r.family == "jar" and r.tasks.count == 26 and r.tasks.hold_steps == 10
    assert r.spec.proposition_names == ("jar_on_support", "jar_closed", "jar_dropped", "jar_upright")
    assert [p.name for p in r.success] == ["jar_in_goal", "jar_closed", "jar_held"]
    assert all(lo <= hi for lo, hi in r.variation.values())
    assert r.digest == load_recipe(recipes_dir() / "jar.toml").digest


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        ("count = 26", "count = 0", "[tasks] count = 0"),
        ("count = 26", 'count = "many"', "count = 'many' should be a int"),
        ("horizon = 2000", "horizonn = 2000", "unknown key(s) ['horizonn']"),
        ('cameras = ["front", "left", "right", "shoulder", "wrist"]', 'cameras = ["top"]',
         "cameras = ['top']"),
        ("lift_height = [0.05, 0.08]", "lift_height = [0.08, 0.05]", "[variation] lift_height"),
        ('family = "jar"', 'family = "lid"', "must match the file name"),
        ("[layout]", "[layoutt]", "missing table [layout]"),
    ],
)
def test_bad_recipes_name_file_and_key(tmp_path: Path, old: str, new: str, fragment: str) -> None:
    path = _variant(tmp_path, old, new)
    with pytest.raises(RecipeError) as err:
        load_recipe(path)
    assert str(path) in str(err.value) and fragment in str(err.value)


def test_bad_success_proposition_is_a_spec_error(tmp_path: Path) -> None:
    path = _variant(tmp_path, 'evaluator = "held"', 'evaluator = "grabbed"')
    with pytest.raises(SpecError, match=r"success\.jar_held\.evaluator: unknown evaluator 'grabbed'"):
        load_recipe(path)


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        ('jar_models = ["jar/hinged_*"]', 'jar_models = ["jar/nothing_*"]', "matches no object model"),
        ("goal_distance = [0.18, 0.30]", "goal_distance = [0.9, 1.0]", "no goal position"),
        ("food_clearance = 0.006", "food_clearance = 0.2", "no food item fits"),
    ],
)
def test_bad_layouts_name_the_key(tmp_path: Path, old: str, new: str, fragment: str) -> None:
    recipe = load_recipe(_variant(tmp_path, old, new))
    with pytest.raises(RecipeError, match=fragment):
        base_task(recipe, 0)


def test_unknown_family_and_task() -> None:
    with pytest.raises(UnknownFamilyError, match=r"no recipe for family 'nosuch'.*jar"):
        load_recipe("nosuch")
    with pytest.raises(RecipeError, match="task 26 does not exist"):
        base_task(load_recipe("jar"), 26)
