"""TaskSpec: everything needed to build one task's scene and judge it, produced from a recipe.

A TaskSpec is plain data (no MuJoCo types) so it can be hashed, stored in episode metadata and sent to worker
processes. The scene builder (``mgdata.sim.scene``) turns it into an ``MjModel``/``MjData``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from mgdata.spec import SafetySpec


def _frozen(mapping: Mapping[str, Any] | None = None) -> Mapping[str, Any]:
    return MappingProxyType(dict(mapping or {}))


@dataclass(frozen=True)
class ObjectPlacement:
    """One object instance: ``name`` is its instance name in the scene (``"jar"``, ``"obstacle_0"``),
    ``model`` its asset-library name (``"jar/hinged_03"``). ``pos`` is the object frame's origin in the world
    (m) and ``yaw`` its rotation about world +Z (rad); objects start upright.
    """

    name: str
    model: str
    pos: tuple[float, float, float]
    yaw: float = 0.0


@dataclass(frozen=True)
class GoalRegion:
    """A visual-only goal sphere (no collision)."""

    pos: tuple[float, float, float]
    radius: float
    name: str = "goal"


@dataclass(frozen=True)
class TaskSpec:
    """One task of a family, as a recipe generated it.

    Attributes:
        family: family name (``"jar"``).
        task_id: index of the base task within the family.
        condition: ``"base"`` or an OOD condition name.
        prompt: the instruction text stored with every episode.
        objects: the object instances and their initial poses.
        safety: the safety specification monitored on every step.
        goal: the goal region, if the family has one.
        articulation: instance name -> initial opening fraction of its articulation (0 closed, 1 fully open).
        robot_base: robot base position (m) in the world; the robot faces +X.
        robot_base_yaw: rotation of the robot base about +Z (rad).
        image_size: camera image side (pixels; keyword only, required: e.g. the recipe's ``[tasks]``
            ``image_size``, or ``load_sim_config().cameras.image_size``).
        seed: seed from which the task's own random draws were made.
        params: family tunables the skeleton reads (lift height, standoffs …), copied from the recipe.
        draw: which layout draw of the task this is (the initial-state gate may reject earlier ones).
        gate: facts the initial-state gate established (e.g. ``grasps``: the reachable grasp ids).
        tint: instance name -> RGB tint (0…1) recolouring it (the target OOD variant; material only).
        room: the room style the table stands in (``mgdata.sim.rooms``; ``""``: plain surroundings).
        cameras: the family's third-person framing over ``recipes/sim.toml`` ``[cameras]`` (the recipe's
            ``[cameras]`` table, :func:`mgdata.sim.cameras.parse_family_cameras`; empty: sim.toml's).
    """

    family: str
    task_id: int
    condition: str
    prompt: str
    objects: tuple[ObjectPlacement, ...]
    safety: SafetySpec
    goal: GoalRegion | None = None
    articulation: Mapping[str, float] = field(default_factory=_frozen)
    robot_base: tuple[float, float, float] = (0.0, 0.0, 0.0)
    robot_base_yaw: float = 0.0
    image_size: int = field(kw_only=True)
    seed: int = 0
    params: Mapping[str, Any] = field(default_factory=_frozen)
    draw: int = 0
    gate: Mapping[str, Any] = field(default_factory=_frozen)
    tint: Mapping[str, tuple[float, float, float]] = field(default_factory=_frozen)
    room: str = ""
    cameras: Mapping[str, Any] = field(default_factory=_frozen)

    def object(self, name: str) -> ObjectPlacement:
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise KeyError(name)
