"""The success column every demonstration source records: the recipe's goal predicate, held at rest.

``SuccessCheck(scene, recipe)()`` is true when every ``[success.*]`` proposition of the recipe holds (e.g. the
jar's centre inside the goal sphere, the lid closed, the jar held) **and** the objects those propositions name
are at rest (:class:`~mgdata.episode.gate.RestCheck` with the recipe's ``[tasks] rest_linear_speed`` and
``rest_angular_speed``). A skeleton's extra family check can be passed in as ``extra``. The planner's executor
and the teleop session both record this, so the gate and ``mgdata validate`` read the same column.

Example::

    check = SuccessCheck(scene, recipe)
    recorder = Recorder(scene, task.safety, sink, cameras, lambda scene: check())
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mgdata.episode.gate import RestCheck
from mgdata.sim.labelling import Labeller
from mgdata.sim.predicates import resolve
from mgdata.sim.scene import Scene
from mgdata.spec import SafetySpec
from mgdata.tasks.recipe import Recipe


class SuccessCheck:
    """Goal predicate ∧ (optional extra check) ∧ the goal's objects at rest, on ``scene``'s live state."""

    def __init__(self, scene: Scene, recipe: Recipe) -> None:
        self.scene = scene
        self.goal = Labeller(scene, SafetySpec(f"{recipe.family}_goal", (), recipe.success))
        subjects = dict.fromkeys(n for p in recipe.success for s in p.subjects
                                 for n in resolve(scene, s, "success subject"))
        self.rest = RestCheck(scene.model, [scene.object_body(n) for n in subjects],
                              linear=recipe.tasks.rest_linear_speed, angular=recipe.tasks.rest_angular_speed)

    def __call__(self, extra: Callable[[], bool] | None = None) -> bool:
        return (bool(np.all(self.goal.labels())) and (extra is None or extra())
                and self.rest.at_rest(self.scene.data))
