"""Task draws: a recipe's layout (``[layout]``) drawn into a TaskSpec by the generic placer.

Draw ``d`` of task ``k`` uses ``numpy.random.default_rng(SeedSequence([recipe seed, k, d]))``, so a task never
changes when the count grows and tasks can be drawn one at a time in worker processes. The engine's
initial-state gate (``mgdata.engine.init_gate.base_task``) tries draws 0, 1, … until one passes; this module
only draws.

Example::

    recipe = load_recipe("jar")
    task = draw_task(recipe, 3)          # draw 0 of task 3
"""

from __future__ import annotations

import numpy as np

from mgdata.errors import RecipeError
from mgdata.sim.taskspec import TaskSpec
from mgdata.tasks.placer import place
from mgdata.tasks.recipe import Recipe


def draw_task(recipe: Recipe, task_id: int, draw: int = 0) -> TaskSpec:
    """Draw ``draw`` of base task ``task_id`` (0 … count−1).

    Raises:
        RecipeError: no such task, or the prompt names a field that is not a role.
        LayoutRejected: this draw cannot meet a layout rule (draw again).
    """
    if not 0 <= task_id < recipe.tasks.count:
        raise RecipeError(f"{recipe.path}: task {task_id} does not exist (the recipe has tasks 0 … "
                          f"{recipe.tasks.count - 1})")
    rng = np.random.default_rng(np.random.SeedSequence([recipe.tasks.seed, task_id, draw]))
    try:
        placed = place(recipe.layout, rng)
    except RecipeError as err:
        raise RecipeError(f"{recipe.path}: {err}") from None
    try:
        prompt = recipe.prompt.format(**placed.names)
    except (KeyError, IndexError) as err:
        raise RecipeError(f"{recipe.path}: prompt has an unknown field {err}; fields are the layout's roles "
                          f"({', '.join('{' + n + '}' for n in placed.names)})") from None
    return TaskSpec(
        family=recipe.family,
        task_id=task_id,
        condition="base",
        prompt=prompt,
        objects=placed.objects,
        safety=recipe.spec,
        goal=placed.goal,
        articulation=placed.articulation,
        image_size=recipe.tasks.image_size,
        seed=int(rng.integers(0, 2**31 - 1)),
        params=recipe.params,
        cameras=recipe.cameras,
    )
