"""A real attempt context for skeleton-helper tests: the scene, planner and grasps an attempt sees."""

from __future__ import annotations

from mgdata.engine.executor import Executor
from mgdata.skeleton.context import Context
from mgdata.skeleton.variation import draw_variation


def fresh_context(ex: Executor, draw: int) -> Context:
    """A fresh attempt context (variation draw ``draw``) on ``ex``'s reset scene, the planner synced to it."""
    ex.scene.reset()
    ex.planner.sync(ex.scene.data)
    var = draw_variation(ex.task.family, ex.task.task_id, draw, 0, ex.recipe.variation)
    return Context(ex.task, ex.scene, ex.planner, var, ex.grasps, ex.scene.arm_q())
