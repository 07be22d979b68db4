"""SimConfig: Layer 1's tunables, loaded from ``recipes/sim.toml``.

Three tables, each read into the dataclass that uses it: ``[physics]`` → :class:`~mgdata.sim.world.Physics`
(rates, integrator, solver, friction cone, liquid solver), ``[gripper]`` →
:class:`~mgdata.sim.robot.GripperConfig` (servo retuning, finger contact model) and ``[cameras]`` →
:class:`~mgdata.sim.cameras.CameraLayout` (placements, field of view, default image size). Every key is
optional (the dataclass default applies); an unknown table or key, a value of the wrong type or a value out
of range is one :class:`~mgdata.errors.RecipeError` naming the file and the key.

Example::

    sim = load_sim_config()                          # recipes/sim.toml
    scene = build_scene(task, sim=dataclasses.replace(sim, physics=Physics(timestep=0.001)))
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mgdata.errors import RecipeError
from mgdata.paths import recipes_dir
from mgdata.sim.cameras import CameraLayout
from mgdata.sim.robot import GripperConfig
from mgdata.sim.world import Physics

SIM_TOML = "sim.toml"


@dataclass(frozen=True)
class SimConfig:
    """All Layer 1 tunables; ``recipes/sim.toml`` ships the defaults written here."""

    physics: Physics = field(default_factory=Physics)
    gripper: GripperConfig = field(default_factory=GripperConfig)
    cameras: CameraLayout = field(default_factory=CameraLayout)


_VECTORS = {"tuple[float, float]": 2, "Vec3": 3}
"""Vector field types (as annotated) and their lengths."""


def _coerce(value: Any, type_name: str, where: str) -> Any:
    if type_name in _VECTORS:
        n = _VECTORS[type_name]
        if not (isinstance(value, list) and len(value) == n
                and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
            raise RecipeError(f"{where} = {value!r}: expected a list of {n} numbers")
        return tuple(float(v) for v in value)
    expected = {"float": (int, float), "int": (int,), "str": (str,)}[type_name]
    if isinstance(value, bool) or not isinstance(value, expected):
        kind = {"float": "a number", "int": "an integer", "str": "a string"}[type_name]
        raise RecipeError(f"{where} = {value!r}: expected {kind}")
    return float(value) if type_name == "float" else value


def sim_config_from_dict(raw: Mapping[str, Any], source: str = "<dict>") -> SimConfig:
    """A SimConfig from parsed TOML; unknown tables/keys and mistyped or out-of-range values are errors."""
    sections = {f.name: f for f in dataclasses.fields(SimConfig)}
    kwargs: dict[str, Any] = {}
    for name, table in raw.items():
        if name not in sections:
            raise RecipeError(f"{source}: unknown table [{name}]; expected one of {sorted(sections)}")
        if not isinstance(table, dict):
            raise RecipeError(f"{source}: {name} must be a table ([{name}])")
        cls = sections[name].default_factory  # type: ignore[misc]
        fields = {f.name: str(f.type) for f in dataclasses.fields(cls)}
        values = {}
        for key, value in table.items():
            if key not in fields:
                raise RecipeError(f"{source}: unknown key [{name}] {key}; expected one of {sorted(fields)}")
            values[key] = _coerce(value, fields[key], f"{source}: [{name}] {key}")
        try:
            kwargs[name] = cls(**values)
        except RecipeError as exc:
            raise RecipeError(f"{source}: {exc}") from None
    return SimConfig(**kwargs)


def load_sim_config(path: Path | str | None = None) -> SimConfig:
    """Load ``recipes/sim.toml`` (or ``path``); a missing default file means all defaults."""
    file = Path(path) if path is not None else recipes_dir() / SIM_TOML
    if not file.is_file():
        if path is not None:
            raise RecipeError(f"simulation settings file {file} does not exist")
        return SimConfig()
    try:
        raw = tomllib.loads(file.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise RecipeError(f"{file}: not valid TOML: {exc}") from None
    return sim_config_from_dict(raw, str(file))


def default_image_size() -> int:
    """``recipes/sim.toml`` ``[cameras] image_size``: the image side where a recipe or task sets none."""
    return load_sim_config().cameras.image_size
