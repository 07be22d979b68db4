"""Recipe loading: the shipped jar recipe, and one clear error per kind of bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from mgdata.engine.init_gate import base_task
from mgdata.errors import RecipeError, SpecError, UnknownFamilyError
from mgdata.paths import recipes_dir
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeletons.jar import JarSkeleton
from mgdata.tasks.recipe import family_recipes, load_recipe


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
        ('skeleton = "jar"\n', "", "missing key 'skeleton'"),
        ('skeleton = "jar"', 'skeleton = "jar.py"', "skeleton = 'jar.py' must name a module"),
        ("image_size = 256", "image_size = 100000", "image_size = 100000 is out of range (expected an"),
        ('cameras = ["front", "left", "right", "shoulder", "wrist"]', "cameras = 5", "cameras = 5: expected"),
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
        ('models = ["jar/hinged_*"]', 'models = ["jar/nothing_*"]', "match no object model"),
        ("distance = [0.18, 0.30]", "distance = [0.9, 1.0]",
         "most often (20×) [layout] goal: no goal centre 0.9–1 m from jar inside the region after 200"),
        ("clearance = 0.006", "clearance = 0.9", "clearance = 0.9: expected a number in [0, 0.5]"),
        ("clearance = 0.006", "clearance = 0.09",
         "roles.jar models: what goes inside (food) fits in none of them"),
        ("open = 1.0", 'open = "open"', "open = 'open': expected a number in [0, 1]"),
        ("height = [0.10, 0.10]", "height = [nan, 0.0]", "height = [nan, 0.0]: expected [low, high]"),
        ("region = { x = [0.38, 0.62]", "region = { x = [0.62, 0.38]", "region x = [0.62, 0.38]: expected"),
        ('models = ["jar/hinged_*"]', "models = [5]", "models: expected a list of model names"),
        ('candy = "piece of candy"', "candy = 5", "names: expected a table of model, kind or category"),
        ('inside = "jar"', 'inside = "lid"', "inside = 'lid': expected a role listed before this one (jar)"),
        ('rule = "away"', 'rule = "sideways"', "rule = 'sideways': expected one of away, toward"),
        ("[layout.goal]", "[layout.gaol]", "unknown key(s) ['gaol']"),
        ("{food}", "{sauce}", "prompt has an unknown field 'sauce'; fields are the layout's roles"),
    ],
)
def test_bad_layouts_name_the_key(tmp_path: Path, old: str, new: str, fragment: str) -> None:
    with pytest.raises(RecipeError) as err:
        base_task(load_recipe(_variant(tmp_path, old, new)), 0)
    assert fragment in str(err.value)


def test_unknown_family_and_task() -> None:
    with pytest.raises(UnknownFamilyError, match=r"no recipe for family 'nosuch'.*jar"):
        load_recipe("nosuch")
    with pytest.raises(RecipeError, match="task 26 does not exist"):
        base_task(load_recipe("jar"), 26)


# --- the recipe against what the skeleton declares it reads (issue 8 §5) ---------------------------------


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [
        ("lift_height = [0.05, 0.08]", "lift_heigth = [0.05, 0.08]",
         "[variation] unknown key 'lift_heigth'; did you mean 'lift_height'? (known: grasp_standoff,"),
        ("carry_speed = 0.5", "carry_sped = 0.5",
         "[params] unknown key 'carry_sped'; did you mean 'carry_speed'?"),
        ("open_steps = 8 ", "", "[params] missing key(s) 'open_steps'"),
        ("goal_dx = [-0.012, 0.012]", "", "[variation] missing key(s) 'goal_dx'"),
        ("open_steps = 8 ", 'open_steps = "eight" ',
         "[params] open_steps = 'eight': expected an integer in [1, 200]"),
        ("open_steps = 8 ", "open_steps = 8.5 ", "[params] open_steps = 8.5: expected an integer"),
        ("carry_speed = 0.5", "carry_speed = 3.0",
         "[params] carry_speed = 3.0: expected a number in [0.01, 1]"),
        ("carry_speed = 0.5", "carry_speed = true", "[params] carry_speed = true: expected a number"),
        ("carry_yaws_deg = [0, 30", "carry_yaws_deg = [0, 'x', 30", "[params] carry_yaws_deg = [0, 'x', 30"),
        ("lift_height = [0.05, 0.08]", "lift_height = [0.05, 0.9]",
         "[variation] lift_height = [0.05, 0.9]: outside the allowed range [0, 0.3]"),
        ("lift_height = [0.05, 0.08]", "lift_height = [0.08, 0.05]",
         "[variation] lift_height = [0.08, 0.05]: expected [low, high]"),
        ("lift_height = [0.05, 0.08]", "lift_height = [nan, 0.08]", "[variation] lift_height = [nan, 0.08]"),
        ("lift_height = [0.05, 0.08]", "lift_height = 0.06",
         "[variation] lift_height = 0.06: expected [low, high]"),
    ],
)
def test_recipe_is_checked_against_skeleton_keys(tmp_path: Path, old: str, new: str, fragment: str) -> None:
    path = _variant(tmp_path, old, new)
    with pytest.raises(RecipeError) as err:
        load_family_recipe(path)
    assert str(path) in str(err.value) and fragment in str(err.value), str(err.value)


def test_checked_recipe_has_typed_values() -> None:
    recipe = load_family_recipe("jar")
    declared = JarSkeleton.recipe_keys
    assert list(recipe.params) == [p.name for p in declared.params]
    assert list(recipe.variation) == [k.name for k in declared.variation]
    for p in declared.params:
        value = recipe.params[p.name]
        if p.kind is tuple:
            assert isinstance(value, tuple) and all(type(v) is float for v in value)
        else:
            assert type(value) is p.kind, p.name
    assert recipe.params["carry_yaws_deg"][:3] == (0.0, 30.0, -30.0)
    assert all(type(lo) is float and lo <= hi for lo, hi in recipe.variation.values())


def test_unknown_family_lists_only_family_recipes() -> None:
    with pytest.raises(UnknownFamilyError) as err:
        load_recipe("nosuch")
    message = str(err.value)
    assert f"(family recipes: {', '.join(family_recipes())})" in message
    assert {"jar", "clutter_dry", "dusty", "lid"} <= set(family_recipes())
    assert "sim" not in message.split("recipes:")[1]
