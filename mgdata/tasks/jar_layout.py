"""Jar family layout: one hinged jar with its lid open and a food item inside, and a goal sphere on the table.

Rules (all numbers from the recipe's ``[layout]`` table):

* the jar model is drawn from ``jar_models`` (glob patterns over the asset library), the food from ``foods``
  among the items that fit through the jar's mouth and under its lid with ``food_clearance`` to spare;
* the jar stands at ``jar_x`` × ``jar_y`` (robot base frame, metres) turned so that its hinge (local −X) faces
  the robot, give or take ``jar_yaw_jitter_deg``: the open lid leans towards the robot, and a push away from
  the robot swings it past vertical so that gravity closes it;
* the goal sphere's centre is ``goal_height`` above the table, ``goal_distance`` from the jar, inside the
  ``goal_x`` × ``goal_y`` box; its radius is ``goal_radius``;
* the lid starts at ``lid_open`` (fraction of the hinge range, 1 = leaning on its stop).

Example::

    task = jar_task(load_recipe("jar"), task_id=0, rng=np.random.default_rng(...))
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from mgdata.errors import RecipeError
from mgdata.sim.assets import get_model, model_names
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.tasks.recipe import Recipe
from mgdata.tasks.taskspec import GoalRegion, ObjectPlacement, TaskSpec

_KEYS = ("jar_models", "foods", "food_names", "food_clearance", "jar_x", "jar_y", "jar_yaw_jitter_deg",
         "goal_x", "goal_y", "goal_distance", "goal_height", "goal_radius", "lid_open")
_TRIES = 200


def jar_task(recipe: Recipe, task_id: int, rng: np.random.Generator) -> TaskSpec:
    """Base task ``task_id`` of the jar family, drawn with ``rng``."""
    lay, src = recipe.layout, f"{recipe.path}: [layout]"
    missing = [k for k in _KEYS if k not in lay]
    unknown = sorted(set(lay) - set(_KEYS))
    if missing or unknown:
        raise RecipeError(f"{src} missing key(s) {missing} / unknown key(s) {unknown}")
    clearance = _number(lay, "food_clearance", src, 0.0, 0.1)
    jitter_deg = _number(lay, "jar_yaw_jitter_deg", src, 0.0, 90.0)
    goal_height = _number(lay, "goal_height", src, 0.0, 1.0)
    goal_radius = _number(lay, "goal_radius", src, 0.005, 0.5)
    lid_open = _number(lay, "lid_open", src, 0.0, 1.0)
    for key in ("jar_x", "jar_y", "goal_x", "goal_y", "goal_distance"):
        _bounds(lay[key], f"{src} {key}")
    jars = _models(lay["jar_models"], f"{src} jar_models")
    foods = _models(lay["foods"], f"{src} foods")
    jar_name = jars[int(rng.integers(len(jars)))]
    jar = get_model(jar_name)
    geo = jar.geometry
    room_w = 2.0 * geo["mouth_radius"] - clearance
    room_h = geo["height"] - geo["bottom"] - clearance
    fitting = [f for f in foods if get_model(f).geometry["width"] <= room_w
               and get_model(f).geometry["height"] <= room_h]
    if not fitting:
        raise RecipeError(f"{src} foods: no food item fits inside {jar_name} (mouth {room_w * 100:.1f} cm)")
    food_name = fitting[int(rng.integers(len(fitting)))]
    kind = str(get_model(food_name).geometry["kind"])
    names: Mapping[str, Any] = lay["food_names"]
    if not isinstance(names, Mapping) or not all(isinstance(v, str) for v in names.values()):
        raise RecipeError(f"{src} food_names: expected a table of food kind = display name, got {names!r}")
    if kind not in names:
        raise RecipeError(f"{src} food_names has no display name for food kind {kind!r}")

    jx, jy = _uniform(rng, lay["jar_x"], f"{src} jar_x"), _uniform(rng, lay["jar_y"], f"{src} jar_y")
    jitter = math.radians(_uniform(rng, [-jitter_deg, jitter_deg], src))
    yaw = math.atan2(jy, jx) + jitter
    goal = _goal(rng, lay, (jx, jy), src)
    z = TABLE_TOP_Z
    objects = (
        ObjectPlacement("jar", jar_name, (jx, jy, z), yaw),
        ObjectPlacement("food", food_name, (jx, jy, z + geo["bottom"] + 0.001), yaw),
    )
    try:
        prompt = recipe.prompt.format(food=names[kind])
    except (KeyError, IndexError) as err:
        raise RecipeError(f"{recipe.path}: prompt has an unknown field {err}; jar prompts may use {{food}}"
                          ) from None
    return TaskSpec(
        family=recipe.family,
        task_id=task_id,
        condition="base",
        prompt=prompt,
        objects=objects,
        safety=recipe.spec,
        goal=GoalRegion((goal[0], goal[1], z + goal_height), goal_radius),
        articulation={"jar": lid_open},
        image_size=recipe.tasks.image_size,
        seed=int(rng.integers(0, 2**31 - 1)),
        params=recipe.params,
    )


def _models(patterns: Any, where: str) -> list[str]:
    if isinstance(patterns, str):
        patterns = [patterns]
    if not isinstance(patterns, list) or not patterns or not all(isinstance(p, str) for p in patterns):
        raise RecipeError(f"{where}: expected a list of model names or glob patterns")
    everything = model_names()
    found = [n for n in everything if any(fnmatch.fnmatchcase(n, p) for p in patterns)]
    if not found:
        raise RecipeError(f"{where} = {patterns!r} matches no object model")
    return found


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _number(lay: Mapping[str, Any], key: str, src: str, low: float, high: float) -> float:
    value = lay[key]
    if not _finite(value) or not low <= value <= high:
        raise RecipeError(f"{src} {key} = {value!r}: expected a number in [{low:g}, {high:g}]")
    return float(value)


def _bounds(bounds: Any, where: str) -> tuple[float, float]:
    ok = isinstance(bounds, list) and len(bounds) == 2 and all(map(_finite, bounds))
    if not ok or bounds[0] > bounds[1]:
        raise RecipeError(f"{where}: expected [low, high], two numbers with low <= high, got {bounds!r}")
    return float(bounds[0]), float(bounds[1])


def _uniform(rng: np.random.Generator, bounds: Any, where: str) -> float:
    return float(rng.uniform(*_bounds(bounds, where)))


def _goal(rng: np.random.Generator, lay: Mapping[str, Any], jar: tuple[float, float],
          src: str) -> tuple[float, float]:
    dist = lay["goal_distance"]
    for _ in range(_TRIES):
        d = _uniform(rng, dist, f"{src} goal_distance")
        bearing = float(rng.uniform(-math.pi, math.pi))
        gx, gy = jar[0] + d * math.cos(bearing), jar[1] + d * math.sin(bearing)
        if lay["goal_x"][0] <= gx <= lay["goal_x"][1] and lay["goal_y"][0] <= gy <= lay["goal_y"][1]:
            return gx, gy
    raise RecipeError(f"{src}: no goal position {dist} m from the jar at {jar} fits inside goal_x × goal_y "
                      f"after {_TRIES} draws; widen the box or shorten goal_distance")
