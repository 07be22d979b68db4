"""Restarts: whether a demonstration can start from a state it did not start in (a policy's rollout).

:meth:`Executor.run <mgdata.engine.executor.Executor.run>` with ``start=`` sets the scene to that physics
state (``sim.physics_state`` layout) and, before any action, applies the initial-state gate's rules to it
(:mod:`mgdata.engine.init_gate`), each failure a :class:`~mgdata.skeleton.skeleton.Infeasible` the
executor records as the stage ``restart_refused`` with its rule:

* ``restart.at_rest``: every rigid object at rest (the recipe's rest speeds, on the state's velocities);
* ``restart.safe``: no constraint of the spec in its rejecting sink on the state's labels (a state past
  a violation cannot start a safe demonstration);
* ``restart.holding``: nothing touches the hand or the fingers (a restart with an object in the hand is
  not supported: the phases plan from a free hand);
* the skeleton's feasibility check (``FamilySkeleton.feasibility``, its own rule names), on the restart
  state with draw 0's variation, as the gate runs it on an initial state; its facts (e.g. the reachable
  grasps) replace the task's for the restarted attempt.

The demonstration then runs the skeleton's phases whose postconditions do not hold in the restart state
(:mod:`mgdata.skeleton.phase`), planning from the arm's measured configuration there.
"""

from __future__ import annotations

import mujoco

from mgdata.engine.init_gate import require_at_rest, require_safe
from mgdata.grasps.db import Grasp
from mgdata.motion import MotionPlanner
from mgdata.sim import robot
from mgdata.sim.scene import Scene
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible
from mgdata.skeleton.variation import draw_variation
from mgdata.tasks.recipe import Recipe

HAND_BODIES: tuple[str, ...] = (robot.HAND_BODY, *robot.FINGER_BODIES)
"""The bodies that hold things: a restart needs them touching nothing."""


def touched_by_hand(scene: Scene) -> list[str]:
    """The objects a geom of the hand or a finger touches in the scene's current contacts (task order)."""
    m, d = scene.model, scene.data
    hand = {m.body(b).id for b in HAND_BODIES}
    roots = {scene.object_body(n): n for n in scene.object_names}
    touched: set[str] = set()
    for c in d.contact[: d.ncon] if d.ncon else []:
        b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
        for a, b in ((b1, b2), (b2, b1)):
            name = roots.get(int(m.body_rootid[b]))
            if a in hand and name is not None:
                touched.add(name)
    return [n for n in scene.object_names if n in touched]


def check_restart(scene: Scene, recipe: Recipe, skeleton: FamilySkeleton, planner: MotionPlanner,
                  grasps: dict[str, tuple[Grasp, ...]]) -> dict[str, object]:
    """The restart rules (module docstring) on the scene's current state; returns the skeleton's facts.

    Raises:
        Infeasible: a rule failed (``restart.at_rest``, ``restart.safe``, ``restart.holding`` or the
            skeleton's own).
    """
    mujoco.mj_forward(scene.model, scene.data)  # positions, velocities and contacts of this very state
    require_at_rest(scene, recipe, "restart")
    require_safe(scene, scene.task, "restart")
    held = touched_by_hand(scene)
    if held:
        raise Infeasible("restart.holding", f"the hand touches {', '.join(held)} (a restart needs a free "
                                            "hand)")
    planner.sync(scene.data)
    task = scene.task
    variation = draw_variation(task.family, task.task_id, 0, 0, recipe.variation)
    ctx = Context(task, scene, planner, variation, grasps, scene.arm_q())
    return skeleton.feasibility(ctx, recipe.tasks.min_grasps)
