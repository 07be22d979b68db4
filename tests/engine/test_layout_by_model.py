"""A layout's ``by_model`` overrides: a drawn model matching a glob is placed by the override (region, near,
yaw, clearance, open; the goal keyed by the model drawn for its ``from`` role), other models by the role's
own rule, an override draws no extra random numbers, and every bad override is a RecipeError naming it.
Layout draws only, no simulation."""

from __future__ import annotations

import copy
import math
import tomllib
from typing import Any

import numpy as np
import pytest

from mgdata.errors import RecipeError
from mgdata.tasks.layout_rules import parse_layout
from mgdata.tasks.placer import LayoutRejected, place

BASE_REGION = {"x": [0.44, 0.56], "y": [-0.16, 0.16]}
BOARD_REGION = {"x": [-0.07, -0.03], "y": [0.33, 0.37]}
GOAL_REGION = {"x": [0.34, 0.62], "y": [-0.34, 0.34]}
BOARD_GOAL_REGION = {"x": [-0.15, 0.0], "y": [0.28, 0.42]}
SEEDS = range(120)

RECIPE = """
[layout.roles.target]
models = ["box/*", "board/*"]
region = { x = [0.44, 0.56], y = [-0.16, 0.16] }
yaw = { rule = "away", jitter_deg = 40.0 }
clearance = 0.03
by_model."board/*" = { region = { x = [-0.07, -0.03], y = [0.33, 0.37] }, yaw = { rule = "fixed", deg = 0.0, jitter_deg = 3.0 } }

[layout.goal]
from = "target"
distance = [0.18, 0.32]
region = { x = [0.34, 0.62], y = [-0.34, 0.34] }
height = [0.16, 0.26]
radius = { scale = 0.45, of = "target", min = 0.03 }
clearance = 0.03
by_model."board/*" = { distance = [0.0, 0.12], region = { x = [-0.15, 0.0], y = [0.28, 0.42] } }
"""  # noqa: E501


def _raw() -> dict[str, Any]:
    return tomllib.loads(RECIPE)["layout"]


def _inside(pos: tuple[float, ...], region: dict[str, list[float]]) -> bool:
    return region["x"][0] <= pos[0] <= region["x"][1] and region["y"][0] <= pos[1] <= region["y"][1]


def _angle(a: float, b: float) -> float:
    """|a - b| (rad) wrapped into [0, pi]."""
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


def test_a_matching_model_is_placed_by_the_override_others_by_the_role() -> None:
    layout = parse_layout(_raw(), "test")
    target = layout.role("target")
    assert [g for g, _ in target.by_model] == ["board/*"]
    assert target.for_model("box/carton_00") is target
    assert target.for_model("board/chopping_03").yaw.rule == "fixed"
    kinds = set()
    for seed in SEEDS:
        placed = place(layout, np.random.default_rng(seed))
        obj, goal = placed.objects[0], placed.goal
        assert goal is not None
        kind = obj.model.split("/")[0]
        kinds.add(kind)
        reach = math.dist(obj.pos[:2], goal.pos[:2])
        if kind == "board":
            assert _inside(obj.pos, BOARD_REGION), (seed, obj)
            assert _angle(obj.yaw, 0.0) <= math.radians(3.0) + 1e-9, (seed, obj)
            assert _inside(goal.pos, BOARD_GOAL_REGION) and reach <= 0.12 + 1e-9, (seed, goal)
        else:
            assert _inside(obj.pos, BASE_REGION), (seed, obj)
            away = math.atan2(obj.pos[1], obj.pos[0])
            assert _angle(obj.yaw, away) <= math.radians(40.0) + 1e-9, (seed, obj)
            assert _inside(goal.pos, GOAL_REGION) and 0.18 - 1e-9 <= reach <= 0.32 + 1e-9, (seed, goal)
    assert kinds == {"board", "box"}


def test_an_override_draws_no_extra_numbers() -> None:
    """An override that repeats the role's own rule changes nothing: same draws, same order."""
    plain = _raw()
    del plain["roles"]["target"]["by_model"], plain["goal"]["by_model"]
    same = copy.deepcopy(plain)
    same["roles"]["target"]["by_model"] = {"board/*": {"region": BASE_REGION, "clearance": 0.03}}
    same["goal"]["by_model"] = {"board/*": {"distance": [0.18, 0.32]}}
    a, b = parse_layout(plain, "test"), parse_layout(same, "test")
    for seed in range(40):
        assert place(a, np.random.default_rng(seed)) == place(b, np.random.default_rng(seed))


def test_an_override_may_switch_region_to_near() -> None:
    raw = {"roles": {
        "anchor": {"models": ["cup/*"], "region": {"x": [0.5, 0.5], "y": [0.0, 0.0]}},
        "item": {"models": ["box/*", "board/*"], "region": {"x": [0.45, 0.45], "y": [0.35, 0.35]},
                 "by_model": {"box/*": {"near": "anchor", "distance": [0.2, 0.2], "bearing_deg": [90, 90]}}}}}
    layout = parse_layout(raw, "test")
    box_rule = layout.role("item").for_model("box/carton_00")
    assert (box_rule.placement, box_rule.host, box_rule.region) == ("near", "anchor", None)
    for seed in range(30):
        anchor, item = place(layout, np.random.default_rng(seed)).objects
        if item.model.startswith("box/"):
            assert math.dist(item.pos[:2], anchor.pos[:2]) == pytest.approx(0.2)
        else:
            assert item.pos[:2] == (0.45, 0.35)


def test_the_override_clearance_keeps_later_objects_away() -> None:
    """The board's clearance (0.5 m) rules out a cup 0.35 m away; a box keeps the role's (none)."""
    raw = {"roles": {
        "target": {"models": ["box/*", "board/*"], "region": {"x": [0.5, 0.5], "y": [0.0, 0.0]},
                   "by_model": {"board/*": {"clearance": 0.5}}},
        "cup": {"models": ["cup/*"], "region": {"x": [0.5, 0.5], "y": [0.35, 0.35]}}}}
    layout = parse_layout({**raw, "tries": 3}, "test")
    outcomes = set()
    for seed in range(30):
        try:
            placed = place(layout, np.random.default_rng(seed))
            outcomes.add(placed.objects[0].model.split("/")[0])
        except LayoutRejected as err:
            assert "roles.cup" in err.rule
            outcomes.add("rejected")
    assert outcomes == {"box", "rejected"}


def test_an_override_sets_the_opening() -> None:
    raw = {"roles": {"cabinet": {"models": ["cabinet/*"], "region": {"x": [0.5, 0.5], "y": [0.0, 0.0]},
                                 "open": 1.0, "by_model": {"cabinet/drawer_00": {"open": 0.0}}}}}
    layout = parse_layout(raw, "test")
    seen = {}
    for seed in range(40):
        placed = place(layout, np.random.default_rng(seed))
        seen[placed.objects[0].model] = placed.articulation["cabinet"]
    assert seen["cabinet/drawer_00"] == 0.0
    assert set(v for m, v in seen.items() if m != "cabinet/drawer_00") == {1.0}


def _role_override(override: Any) -> dict[str, Any]:
    raw = _raw()
    raw["roles"]["target"]["by_model"] = {"board/*": override}
    return raw


def _goal_override(override: Any) -> dict[str, Any]:
    raw = _raw()
    raw["goal"]["by_model"] = {"board/*": override}
    return raw


@pytest.mark.parametrize(("raw", "message"), [
    (_role_override({"models": ["board/*"]}), 'by_model."board/*": models cannot vary by model'),
    (_role_override({"count": 2}), "count cannot vary by model"),
    (_role_override({"same_model": True}), "same_model cannot vary by model"),
    (_role_override({"model_of": {"role": "target", "key": "lid"}}), "model_of cannot vary by model"),
    (_role_override({"on": "target"}), "on cannot vary by model"),
    (_role_override({"inside": "target"}), "inside cannot vary by model"),
    (_role_override({"by_model": {"board/chopping_00": {}}}), "by_model cannot vary by model"),
    (_role_override({"colour": "red"}), "unknown key(s) ['colour']"),
    (_role_override(0.5), 'by_model."board/*" = 0.5: expected a table'),
    (_role_override({"region": {"x": [0.5, 0.4], "y": [0.0, 0.1]}}), 'by_model."board/*" region x'),
    (_role_override({"distance": [0.1, 0.2]}), "distance: only a `near` placement reads it"),
    (_role_override({"near": "nobody", "distance": [0.1, 0.2]}), "near = 'nobody'"),
    ({**_raw(), "roles": {"target": {**_raw()["roles"]["target"], "by_model": 3}}},
     "by_model: expected a table of model glob"),
    (_goal_override({"from": "target"}), 'goal by_model."board/*": from cannot vary by model'),
    (_goal_override({"by_model": {}}), "by_model cannot vary by model"),
    (_goal_override({"yaw": {"rule": "away"}}), "unknown key(s) ['yaw']"),
    (_goal_override("near"), 'goal by_model."board/*" = \'near\': expected a table'),
    (_goal_override({"clear_of": ["nobody"]}), "clear_of = ['nobody']"),
])
def test_a_bad_override_names_the_problem(raw: dict[str, Any], message: str) -> None:
    with pytest.raises(RecipeError) as err:
        parse_layout(raw, "r.toml: [layout]")
    assert message in str(err.value)
    assert "r.toml: [layout]" in str(err.value)


def test_an_inside_or_on_role_cannot_vary_by_model() -> None:
    raw = {"roles": {"jar": {"models": ["jar/*"], "region": BASE_REGION},
                     "food": {"models": ["food/*"], "inside": "jar",
                              "by_model": {"food/*": {"clearance": 0.01}}}}}
    with pytest.raises(RecipeError, match=r"roles\.food by_model: only a role placed by region or near"):
        parse_layout(raw, "test")


@pytest.mark.parametrize("where", ["roles", "goal"])
def test_a_glob_matching_none_of_the_roles_models_is_named(where: str) -> None:
    raw = _raw()
    table = raw["roles"]["target"] if where == "roles" else raw["goal"]
    table["by_model"] = {"tray/*": table["by_model"]["board/*"]}
    layout = parse_layout(raw, "test")
    with pytest.raises(RecipeError) as err:
        place(layout, np.random.default_rng(0))
    assert 'by_model."tray/*" matches none of role target\'s models (box/*, board/*)' in str(err.value)
