"""The initial-state gate (paper, "Scene generation"): a base task is accepted only if it can be done safely.

:func:`base_task` draws task ``k`` (``mgdata.tasks.base.draw_task``, draws 0, 1, …) until a draw passes, at
most ``[tasks] max_draws`` times. A draw passes when

1. the placer meets every layout rule (no :class:`~mgdata.tasks.placer.LayoutRejected`);
2. after the scene's passive settle, every rigid object is at rest (``[tasks] rest_linear_speed`` /
   ``rest_angular_speed``);
3. the labels of s₀ leave no constraint of the safety spec in its rejecting sink (nothing starts dropped,
   tipped over or spilled);
4. the skeleton's own check passes (``FamilySkeleton.feasibility``): for pick-and-carry, at least
   ``[tasks] min_grasps`` valid grasps of the target are reachable and collision-free by IK (pre-grasp and
   grasp), and the goal is reachable with the object held.

A task with no passing draw is a :class:`~mgdata.errors.RecipeError` naming the rule that failed most often.
The accepted task records its draw and the skeleton's facts (``TaskSpec.draw``, ``TaskSpec.gate``), so a
worker does not redo the skeleton's search. Results are cached per process.

Example::

    task = base_task(load_family_recipe("clutter_dry"), 3)
    task.draw, task.gate["grasps"]
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from functools import cache
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from mgdata.episode.gate import RestCheck
from mgdata.errors import RecipeError
from mgdata.grasps.db import GraspDB
from mgdata.ltl.monitor import Monitor
from mgdata.motion import MotionPlanner
from mgdata.motion.config import load_motion_config
from mgdata.paths import grasps_dir
from mgdata.sim.labelling import Labeller
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import TaskSpec
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import Infeasible, skeleton_for
from mgdata.skeleton.variation import draw_variation
from mgdata.tasks.base import draw_task
from mgdata.tasks.placer import LayoutRejected
from mgdata.tasks.recipe import Recipe


def check_initial_state(task: TaskSpec, recipe: Recipe, grasps: GraspDB) -> dict[str, Any]:
    """Gate checks 2–4 on ``task``; returns the skeleton's facts or raises :class:`Infeasible`."""
    scene = build_scene(task)
    require_at_rest(scene, recipe)
    require_safe(scene, task)
    planner = MotionPlanner(scene.model, load_motion_config())
    planner.sync(scene.data)
    valid = {o.name: grasps.grasps(o.model, status="valid") for o in task.objects
             if o.model in grasps.objects}
    variation = draw_variation(task.family, task.task_id, 0, 0, recipe.variation)
    ctx = Context(task, scene, planner, variation, valid, scene.arm_q())
    return skeleton_for(recipe.skeleton).feasibility(ctx, recipe.tasks.min_grasps)


def base_task(recipe: Recipe, task_id: int, grasps: Path | None = None) -> TaskSpec:
    """Base task ``task_id``: its first draw that passes the gate (see the module docstring).

    Raises:
        RecipeError: no such task, or no draw passed within ``[tasks] max_draws``.
    """
    folder = grasps or grasps_dir()
    key = (str(recipe.path), recipe.digest, task_id, str(folder))
    if key not in _ACCEPTED:
        _ACCEPTED[key] = _gated(recipe, task_id, folder)
    return _ACCEPTED[key]


def base_tasks(recipe: Recipe, grasps: Path | None = None) -> tuple[TaskSpec, ...]:
    """All base tasks of the recipe, in task order."""
    return tuple(base_task(recipe, k, grasps) for k in range(recipe.tasks.count))


@cache
def cached_grasp_db(folder: Path) -> GraspDB:
    """The grasp database in ``folder``, loaded once per process (shared by the gate and the scenarios)."""
    return GraspDB.load_dir(folder)


_ACCEPTED: dict[tuple[str, str, int, str], TaskSpec] = {}


def forget_base_tasks() -> None:
    """Drop the base tasks this process has gated (a benchmark's next run then pays its own gate)."""
    _ACCEPTED.clear()


def _gated(recipe: Recipe, task_id: int, grasps: Path) -> TaskSpec:
    if not 0 <= task_id < recipe.tasks.count:
        raise RecipeError(f"{recipe.path}: task {task_id} does not exist (the recipe has tasks 0 … "
                          f"{recipe.tasks.count - 1})")
    failures: Counter[str] = Counter()
    last: dict[str, str] = {}
    for draw in range(recipe.tasks.max_draws):
        try:
            task = draw_task(recipe, task_id, draw)
            facts = check_initial_state(task, recipe, cached_grasp_db(grasps))
        except (LayoutRejected, Infeasible) as why:
            rule = why.rule
            failures[rule] += 1
            last[rule] = str(why)
            continue
        return dataclasses.replace(task, draw=draw, gate=MappingProxyType(dict(facts)))
    rule, n = failures.most_common(1)[0]
    raise RecipeError(f"{recipe.path}: task {task_id} failed the initial-state gate on all "
                      f"{recipe.tasks.max_draws} draws ([tasks] max_draws); most often ({n}×) {last[rule]}")


def require_at_rest(scene: Scene, recipe: Recipe, rule: str = "init") -> None:
    """Rule ``<rule>.at_rest``: every rigid object moves slower than the recipe's rest speeds."""
    rigid = [n for n, m in scene.objects.items() if m.particles is None]
    rest = RestCheck(scene.model, [scene.object_body(n) for n in rigid],
                     linear=recipe.tasks.rest_linear_speed, angular=recipe.tasks.rest_angular_speed)
    lin, ang = rest.speeds(scene.data)
    if not rest.at_rest(scene.data):
        raise Infeasible(f"{rule}.at_rest", f"objects still moving ({lin:.3f} m/s, {ang:.3f} rad/s)")


def require_safe(scene: Scene, task: TaskSpec, rule: str = "init") -> None:
    """Rule ``<rule>.safe``: the state's labels leave no constraint of the spec in its rejecting sink."""
    state = Monitor(task.safety).step(Labeller(scene, task.safety).labels())
    bad = [c.id for c, v in zip(task.safety.constraints, np.asarray(state.violated), strict=True) if v]
    if bad:
        raise Infeasible(f"{rule}.safe", f"constraint(s) {', '.join(bad)} already violated in the state")
