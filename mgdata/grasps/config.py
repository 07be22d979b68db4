"""Grasp tooling tunables from ``recipes/grasps.toml``: ``[candidates]`` and ``[check]``.

The finger contact model both the check and the generator use is a property of the robot and the physics:
``recipes/sim.toml`` (``mgdata.sim.robot``, ``mgdata.sim.world``).

Every key is optional (the dataclass defaults apply); an unknown section or key, or a value of the wrong
type, is a :class:`~mgdata.errors.RecipeError` naming the file and key.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mgdata.errors import RecipeError
from mgdata.grasps.candidates import CandidateConfig
from mgdata.grasps.check import GraspCheckConfig
from mgdata.paths import recipes_dir

_SECTIONS: dict[str, type] = {"candidates": CandidateConfig, "check": GraspCheckConfig}


@dataclass(frozen=True)
class GraspSettings:
    """``recipes/grasps.toml``: candidate generation and the in-simulation check."""

    candidates: CandidateConfig
    check: GraspCheckConfig


def load_grasp_config(path: Path | None = None) -> GraspSettings:
    """The grasp tooling settings (defaults where the file or a key is missing)."""
    file = Path(path) if path is not None else recipes_dir() / "grasps.toml"
    raw: dict[str, Any] = {}
    if file.is_file():
        try:
            raw = tomllib.loads(file.read_text(encoding="utf-8"))
        except tomllib.TOMLDecodeError as err:
            raise RecipeError(f"{file}: not valid TOML: {err}") from None
    elif path is not None:
        raise RecipeError(f"grasp settings file {file} does not exist")
    unknown = sorted(set(raw) - set(_SECTIONS))
    if "grip" in unknown:
        raise RecipeError(f"{file}: [grip] is no longer a grasp setting: the finger contact model is part of "
                          "the robot and physics, in recipes/sim.toml")
    if unknown:
        raise RecipeError(f"{file}: unknown section(s) {unknown}; expected {sorted(_SECTIONS)}")
    out = {}
    for name, cls in _SECTIONS.items():
        table = raw.get(name, {})
        fields = {f.name: f for f in dataclasses.fields(cls)}
        values = {}
        for key, value in table.items():
            if key not in fields:
                raise RecipeError(f"{file}: unknown key [{name}] {key}; expected one of {sorted(fields)}")
            kind = {"float": (int, float), "int": (int,), "bool": (bool,)}[str(fields[key].type)]
            if isinstance(value, bool) != (fields[key].type == "bool") or not isinstance(value, kind):
                raise RecipeError(f"{file}: [{name}] {key} = {value!r} should be a {fields[key].type}")
            values[key] = float(value) if fields[key].type == "float" else value
        out[name] = cls(**values)
    return GraspSettings(**out)
