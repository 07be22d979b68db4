"""The success column every demonstration source records: the recipe's goal predicate, held at rest.

``SuccessCheck(controller, recipe)()`` is true when every ``[success.*]`` proposition of the recipe holds
(e.g. the jar's centre inside the goal sphere, the lid closed, the jar held) **and** the objects those
propositions name are at rest (:class:`~mgdata.episode.gate.RestCheck` with the recipe's ``[tasks]
rest_linear_speed`` and ``rest_angular_speed``, at every physics substep: the check watches the controller).
A skeleton's extra family check can be passed in as ``extra``. The planner's executor, the teleop session
and evaluation all record this, so the gate and ``mgdata validate`` read the same column.

Example::

    check = SuccessCheck(controller, recipe)
    recorder = Recorder(scene, task.safety, sink, cameras, lambda scene: check())
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mgdata.episode.gate import RestCheck
from mgdata.record.physics_audit import PhysicsGate
from mgdata.sim.controller import JointController
from mgdata.sim.labelling import Labeller
from mgdata.sim.predicates import resolve
from mgdata.spec import SafetySpec
from mgdata.tasks.recipe import Recipe


class SuccessCheck:
    """Goal predicate ∧ (optional extra check) ∧ the goal's objects at rest, on the controller's scene's live
    state (at rest over the whole last control period: the rest check watches ``controller``)."""

    def __init__(self, controller: JointController, recipe: Recipe) -> None:
        scene = self.scene = controller.scene
        self.goal = Labeller(scene, SafetySpec(f"{recipe.family}_goal", (), recipe.success))
        subjects = dict.fromkeys(n for p in recipe.success for s in p.subjects
                                 for n in resolve(scene, s, "success subject"))
        self.rest = RestCheck(scene.model, [scene.object_body(n) for n in subjects],
                              linear=recipe.tasks.rest_linear_speed, angular=recipe.tasks.rest_angular_speed)
        controller.watch(self.rest)

    def __call__(self, extra: Callable[[], bool] | None = None) -> bool:
        return (bool(np.all(self.goal.labels())) and (extra is None or extra())
                and self.rest.at_rest(self.scene.data))

    def status(self) -> dict[str, bool]:
        """What holds now: each goal proposition by name, and ``at_rest`` (why a rollout that timed out did
        not succeed)."""
        return {**self.goal.as_dict(), "at_rest": self.rest.at_rest(self.scene.data)}


def physics_gate(recipe: Recipe) -> PhysicsGate:
    """The gate's physical bounds for a family (``info.json`` ``mgdata.physics_gate``, audited by
    ``mgdata validate``): its rest speeds and subjects, and ``max_penetration``."""
    t = recipe.tasks
    subjects = tuple(dict.fromkeys(s for p in recipe.success for s in p.subjects))
    return PhysicsGate(t.rest_linear_speed, t.rest_angular_speed, subjects, t.max_penetration)
