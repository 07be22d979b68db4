"""Base tasks: a recipe's ``[tasks] count`` TaskSpecs, each drawn from its own seed by the family's layout.

Task ``k`` uses ``numpy.random.default_rng(SeedSequence([recipe seed, k]))``, so a task never changes when the
count grows, and tasks can be generated one at a time in worker processes.

Example::

    recipe = load_recipe("jar")
    tasks = base_tasks(recipe)          # 26 jar tasks
    one = base_task(recipe, 3)
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

import numpy as np

from mgdata.errors import RecipeError, UnknownFamilyError
from mgdata.tasks.recipe import Recipe
from mgdata.tasks.taskspec import TaskSpec

Layout = Callable[[Recipe, int, np.random.Generator], TaskSpec]

LAYOUTS: dict[str, str] = {
    "jar": "mgdata.tasks.jar_layout:jar_task",
}
"""Family -> ``module:function`` of its layout builder."""


def layout_for(family: str) -> Layout:
    """The layout builder of ``family``."""
    if family not in LAYOUTS:
        raise UnknownFamilyError(f"no layout builder for family {family!r} (families: {', '.join(LAYOUTS)})")
    module, func = LAYOUTS[family].split(":")
    return getattr(importlib.import_module(module), func)


def base_task(recipe: Recipe, task_id: int) -> TaskSpec:
    """Base task ``task_id`` (0 … count−1) of the recipe's family."""
    if not 0 <= task_id < recipe.tasks.count:
        raise RecipeError(f"{recipe.path}: task {task_id} does not exist (the recipe has tasks 0 … "
                          f"{recipe.tasks.count - 1})")
    rng = np.random.default_rng(np.random.SeedSequence([recipe.tasks.seed, task_id]))
    return layout_for(recipe.family)(recipe, task_id, rng)


def base_tasks(recipe: Recipe) -> tuple[TaskSpec, ...]:
    """All base tasks of the recipe, in task order."""
    return tuple(base_task(recipe, k) for k in range(recipe.tasks.count))
