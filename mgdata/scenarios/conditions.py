"""Which condition an attempt runs under, and a gated base task turned into that condition (the OOD variants
of docs/scenarios.md, each through the same initial-state gate as a base task).

Example::

    condition = attempt_condition("all", draw=7)          # "language": the five conditions in turn
    task, provenance, gate = variant(recipe, base, condition)
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from types import MappingProxyType
from typing import Any

from mgdata.engine.init_gate import Infeasible, cached_grasp_db, check_initial_state
from mgdata.errors import RecipeError, SceneError
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir
from mgdata.sim.taskspec import TaskSpec
from mgdata.tasks.placer import LayoutRejected
from mgdata.tasks.recipe import Recipe
from mgdata.tasks.variants import (
    CONDITIONS,
    environment_variant,
    language_variant,
    location_proposal,
    ood_settings,
    target_variant,
)

GENERATE_CONDITIONS: tuple[str, ...] = (*CONDITIONS, "all")
"""What ``mgdata generate --condition`` accepts: one condition, or ``all`` (:func:`attempt_condition`)."""


def attempt_condition(choice: str, draw: int) -> str:
    """The condition draw ``draw`` of a task is generated in: ``choice``, or for ``all`` the five
    conditions in turn (``CONDITIONS[draw mod 5]``), so a resumed or sharded run cycles the same way."""
    if choice == "all":
        return CONDITIONS[draw % len(CONDITIONS)]
    if choice not in CONDITIONS:
        raise RecipeError(f"--condition {choice!r}: expected one of {', '.join(GENERATE_CONDITIONS)}")
    return choice


def variant(
    recipe: Recipe, base: TaskSpec, condition: str, grasps: GraspDB | None = None
) -> tuple[TaskSpec, dict[str, Any], dict[str, Any]]:
    """Condition ``condition`` of gated base task ``base``: the task, its provenance and the gate's report
    (gated against ``grasps``, default: the project's grasp database).

    Raises:
        RecipeError: unknown condition, or no location proposal passed the gate within ``tries``.
    """
    grasps = grasps or cached_grasp_db(grasps_dir())
    if condition == "base":
        task, provenance = base, {"kind": "base"}
    elif condition == "target":
        task, provenance = target_variant(base, recipe)
    elif condition == "language":
        task, provenance = language_variant(base, recipe)
    elif condition == "environment":
        task, provenance = environment_variant(base, recipe)
    elif condition == "location":
        return _location(recipe, base, grasps)
    else:
        raise RecipeError(f"unknown condition {condition!r}; expected one of {', '.join(CONDITIONS)}")
    try:
        facts = check_initial_state(task, recipe, grasps)
    except Infeasible as why:  # a visual or language change cannot change what the gate sees
        raise RecipeError(f"{recipe.path}: task {base.task_id} {condition} fails the gate: {why}") from None
    task = _with_gate(task, facts)
    return task, provenance, {"passed": True, "attempts": 1, "rejected": {}}


def _location(
    recipe: Recipe, base: TaskSpec, grasps: GraspDB
) -> tuple[TaskSpec, dict[str, Any], dict[str, Any]]:
    tries = ood_settings(recipe).location.tries
    rejected: Counter[str] = Counter()
    last = ""
    for attempt in range(tries):
        try:
            task, provenance = location_proposal(base, recipe, attempt)
            facts = check_initial_state(task, recipe, grasps)
        except (LayoutRejected, Infeasible) as why:
            rejected[why.rule] += 1
            last = str(why)
            continue
        except SceneError as why:  # the scene builder's own check: overlapping initial poses after the move
            rejected["location.scene"] += 1
            last = str(why)
            continue
        return (
            _with_gate(task, facts),
            provenance,
            {"passed": True, "attempts": attempt + 1, "rejected": dict(sorted(rejected.items()))},
        )
    raise RecipeError(
        f"{recipe.path}: task {base.task_id}: no location variant passed the gate in {tries} "
        f"tries ([ood.location] tries); last: {last}"
    )


def _with_gate(task: TaskSpec, facts: dict[str, Any]) -> TaskSpec:
    return dataclasses.replace(task, gate=MappingProxyType(dict(facts)))
