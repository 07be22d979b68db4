"""A stored scenario as a live :class:`~mgdata.sim.scene.Scene`, in its frozen initial state, bit for bit.

The model is the scenario's own compiled MJB (``mgdata.scenarios.store.load_scenario``, hashes checked),
never a rebuild; the :class:`~mgdata.sim.taskspec.TaskSpec` the labeller, monitor and success check need
is read back from ``scenario.json`` (objects as placed, the stored safety spec, goal, articulation, tint,
room). The state is ``state.npy`` (as ``load_scenario`` sets it). The family recipe supplies what a
scenario does not store: the success predicate, ``hold_steps`` and the rest thresholds.

Example::

    restored = restore_scenario(Path("scenarios/jar/task_0000/base"))
    restored.scene.data.time   # 0.0, the frozen state
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from mgdata.errors import DatasetError, RecipeError
from mgdata.record.physics import physics_state, set_physics_state
from mgdata.scenarios.store import load_scenario
from mgdata.sim.assets import get_model
from mgdata.sim.config import load_sim_config
from mgdata.sim.scene import Scene
from mgdata.sim.taskspec import GoalRegion, ObjectPlacement, TaskSpec
from mgdata.spec import SafetySpec, spec_from_mapping
from mgdata.tasks.recipe import Recipe


@dataclass
class RestoredScenario:
    """A scenario ready to roll out: its scene (at the frozen state), metadata, recipe and that state."""

    scene: Scene
    meta: dict[str, Any]
    recipe: Recipe
    state: np.ndarray

    def reset(self) -> None:
        """Back to the frozen initial state."""
        set_physics_state(self.scene.model, self.scene.data, self.state)


def task_from_meta(meta: dict[str, Any], recipe: Recipe, where: str) -> TaskSpec:
    """The TaskSpec a scenario was built from, as ``scenario.json`` records it."""
    try:
        goal = meta["goal"]
        return TaskSpec(
            family=meta["family"], task_id=int(meta["task_id"]), condition=meta["condition"],
            prompt=meta["prompt"],
            objects=tuple(ObjectPlacement(o["name"], o["model"], tuple(o["placed_pos"]),
                                          float(o["placed_yaw"])) for o in meta["objects"]),
            safety=_spec(meta, recipe, where),
            goal=None if goal is None else GoalRegion(tuple(goal["pos"]), float(goal["radius"]),
                                                      goal["name"]),
            articulation=MappingProxyType(dict(meta["articulation"])),
            robot_base=tuple(meta["robot_base"]), robot_base_yaw=float(meta["robot_base_yaw"]),
            image_size=int(meta["image_size"]), seed=int(meta["seed"]), params=recipe.params,
            draw=int(meta["draw"]), gate=MappingProxyType(dict(meta["gate"].get("facts", {}))),
            tint=MappingProxyType({k: tuple(v) for k, v in meta["tint"].items()}), room=meta["room"],
            cameras=MappingProxyType({k: tuple(v) if isinstance(v, list) else v
                                      for k, v in meta.get("camera_framing", {}).items()}))
    except (KeyError, TypeError, ValueError) as err:
        raise DatasetError(f"{where}: not a scenario.json this version reads ({err!r})") from None


def _spec(meta: dict[str, Any], recipe: Recipe, where: str) -> SafetySpec:
    """The stored spec; the recipe's when it is the same spec (``scenario.json`` sorts the propositions, the
    recipe keeps the dataset's column order)."""
    stored = spec_from_mapping(meta["spec"], f"{where}: spec")
    same = (stored.name == recipe.spec.name and stored.constraints == recipe.spec.constraints
            and {p.name: p for p in stored.propositions} == {p.name: p for p in recipe.spec.propositions})
    return recipe.spec if same else stored


def scenario_spec(folder: Path) -> SafetySpec:
    """The safety spec a rollout of the scenario in ``folder`` is monitored with (its ``scenario.json``'s,
    in its recipe's column order), without loading its scene."""
    import json

    from mgdata.skeleton.skeleton import load_family_recipe

    where = Path(folder) / "scenario.json"
    try:
        meta = json.loads(where.read_text(encoding="utf-8"))
        return _spec(meta, load_family_recipe(meta["family"]), str(where))
    except (OSError, json.JSONDecodeError, KeyError, TypeError) as err:
        raise DatasetError(f"{where}: not a scenario.json this version reads ({err!r})") from None


def restore_scenario(folder: Path, recipe: Recipe | None = None) -> RestoredScenario:
    """Load the scenario in ``folder`` (see the module docstring); ``recipe`` defaults to its family's.

    Raises:
        DatasetError: a file is missing or its hash differs; the metadata cannot be read.
        RecipeError: the scenario's physics timestep differs from ``recipes/sim.toml`` (other settings).
    """
    from mgdata.skeleton.skeleton import load_family_recipe

    folder = Path(folder)
    try:
        model, data, meta = load_scenario(folder)
    except FileNotFoundError as err:
        raise DatasetError(f"{folder}: incomplete scenario ({err.filename} is missing)") from None
    recipe = recipe or load_family_recipe(meta["family"])
    sim = load_sim_config()
    if abs(model.opt.timestep - sim.physics.timestep) > 1e-12:
        raise RecipeError(f"{folder}: built with a physics timestep of {model.opt.timestep} s, "
                          f"recipes/sim.toml has {sim.physics.timestep} s; rebuild the scenarios")
    task = task_from_meta(meta, recipe, str(folder / "scenario.json"))
    state = physics_state(model, data)  # load_scenario set it from state.npy
    scene = Scene(task, model, {o.name: get_model(o.model) for o in task.objects}, sim)
    set_physics_state(scene.model, scene.data, state)
    if physics_state(scene.model, scene.data).tobytes() != state.tobytes():
        raise DatasetError(f"{folder}: the restored state differs from the stored one")
    return RestoredScenario(scene, meta, recipe, state)
