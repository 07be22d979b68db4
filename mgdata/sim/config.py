"""SimConfig: Layer 1's tunables, loaded from ``recipes/sim.toml``.

Tables, each read into the dataclass that uses it: ``[physics]`` →
:class:`~mgdata.sim.physics_config.Physics` (rates, integrator, solver, friction cone, liquid solver),
``[gripper]`` → :class:`~mgdata.sim.gripper.GripperConfig` (servo retuning, finger contact model),
``[contact]`` → :class:`~mgdata.sim.object_contact.ObjectContact` (object geoms' contact model),
``[cameras]`` → :class:`~mgdata.sim.cameras.CameraLayout` (placements, field of view, default image size) and
``[render]`` → :class:`~mgdata.sim.render_config.RenderConfig` and ``[look]`` →
:class:`~mgdata.sim.materials.Look` (materials, finishes, lights).
Every key is optional (the dataclass default applies); an unknown table or key, a value of the wrong type or
a value out of range is one :class:`~mgdata.errors.RecipeError` naming the file and the key.

Example::

    sim = load_sim_config()                          # recipes/sim.toml
    scene = build_scene(task, sim=dataclasses.replace(sim, physics=Physics(timestep=0.001)))
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mgdata.paths import recipes_dir
from mgdata.settings import load_settings, settings_from_dict
from mgdata.sim.cameras import CameraLayout
from mgdata.sim.gripper import GripperConfig
from mgdata.sim.materials import Look
from mgdata.sim.object_contact import ObjectContact
from mgdata.sim.physics_config import Physics
from mgdata.sim.render_config import RenderConfig

SIM_TOML = "sim.toml"


@dataclass(frozen=True)
class SimConfig:
    """All Layer 1 tunables; ``recipes/sim.toml`` ships the defaults written here."""

    physics: Physics = field(default_factory=Physics)
    gripper: GripperConfig = field(default_factory=GripperConfig)
    contact: ObjectContact = field(default_factory=ObjectContact)
    cameras: CameraLayout = field(default_factory=CameraLayout)
    render: RenderConfig = field(default_factory=RenderConfig)
    look: Look = field(default_factory=Look)


def sim_config_from_dict(raw: Mapping[str, Any], source: str = "<dict>") -> SimConfig:
    """A SimConfig from parsed TOML; unknown tables/keys and mistyped or out-of-range values are errors."""
    return settings_from_dict(SimConfig, raw, source)


def load_sim_config(path: Path | str | None = None) -> SimConfig:
    """Load ``recipes/sim.toml`` (or ``path``); a missing default file means all defaults."""
    file = Path(path) if path is not None else recipes_dir() / SIM_TOML
    return load_settings(SimConfig, file, explicit=path is not None)


def default_image_size() -> int:
    """``recipes/sim.toml`` ``[cameras] image_size``: the image side where a recipe or task sets none."""
    return load_sim_config().cameras.image_size
