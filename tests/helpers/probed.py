"""One attempt of a task played by a test's own skeleton, with a raw-physics probe as the controller.

The planted-violation tests of every family use it: the attempt is kept whatever happens (``keep_failed``), so
the test can compare the monitor's verdict with what its probe measured from raw MuJoCo data.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, TypeVar

from mgdata.engine.executor import Executor
from mgdata.grasps.db import GraspDB
from mgdata.record.episode import MemorySink
from mgdata.sim.scene import Scene

P = TypeVar("P")


def probed_attempt(task: Any, recipe: Any, grasps: GraspDB, skeleton: Any,
                   probe: Callable[[Scene], P], draw: int = 0) -> tuple[Any, Any, Any, P]:
    """Attempt ``draw`` of ``task`` played by ``skeleton`` with ``probe(scene)`` as the controller: (result,
    frames, episode meta, probe)."""
    ex = Executor(task, recipe, grasps=grasps, render=False)
    ex.skeleton = skeleton
    probed = probe(ex.scene)
    ex.use_controller(probed)
    sink = MemorySink()
    try:
        result = ex.run(draw, sink, keep_failed=True)
    finally:
        ex.close()
    frames, meta = sink.episodes[0]
    return result, frames, meta, probed


def with_penetration_bound(recipe: Any, metres: float) -> Any:
    """``recipe`` with ``[tasks] max_penetration`` set to ``metres``: for a test whose own skeleton crashes
    or spills on purpose (objects shoved, set down hard, liquid poured out) and measures something else."""
    return dataclasses.replace(recipe, tasks=dataclasses.replace(recipe.tasks, max_penetration=metres))
