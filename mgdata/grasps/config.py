"""Grasp tooling tunables from ``recipes/grasps.toml``: ``[candidates]`` and ``[check]``.

The finger contact model both the check and the generator use is a property of the robot and the physics:
``recipes/sim.toml`` (``mgdata.sim.robot``, ``mgdata.sim.world``).

Every key is optional (the dataclass defaults apply); an unknown section or key, or a value of the wrong
type, is a :class:`~mgdata.errors.RecipeError` naming the file and key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mgdata.errors import RecipeError
from mgdata.grasps.candidates import CandidateConfig
from mgdata.grasps.check import GraspCheckConfig
from mgdata.paths import recipes_dir
from mgdata.settings import load_settings, read_toml


@dataclass(frozen=True)
class GraspSettings:
    """``recipes/grasps.toml``: candidate generation and the in-simulation check."""

    candidates: CandidateConfig = field(default_factory=CandidateConfig)
    check: GraspCheckConfig = field(default_factory=GraspCheckConfig)


def load_grasp_config(path: Path | None = None) -> GraspSettings:
    """The grasp tooling settings (defaults where the file or a key is missing)."""
    file = Path(path) if path is not None else recipes_dir() / "grasps.toml"
    if file.is_file() and "grip" in read_toml(file):
        raise RecipeError(f"{file}: [grip] is no longer a grasp setting: the finger contact model is part of "
                          "the robot and physics, in recipes/sim.toml")
    return load_settings(GraspSettings, file, explicit=path is not None)
