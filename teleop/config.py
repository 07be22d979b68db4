"""Teleop tunables from ``recipes/teleop.toml`` (see that file for meanings and units)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mgdata.errors import RecipeError
from mgdata.paths import recipes_dir
from mgdata.settings import load_settings

Vec3 = tuple[float, float, float]
TELEOP_TOML = "teleop.toml"


@dataclass(frozen=True)
class LeaderConfig:
    baudrate: int = 1_000_000
    reader_hz: float = 160.0
    stale_s: float = 0.25
    gripper_threshold: float = 0.5
    max_joint_step: float = 0.15
    still_joint_step: float = 0.002

    def __post_init__(self) -> None:
        if self.still_joint_step < 0.0:
            raise RecipeError(f"[leader] still_joint_step = {self.still_joint_step}: must be >= 0")
        if self.reader_hz < 100.0:
            raise RecipeError(f"[leader] reader_hz = {self.reader_hz}: must be at least 100 Hz")
        if not 0.0 < self.gripper_threshold < 1.0:
            raise RecipeError(f"[leader] gripper_threshold = {self.gripper_threshold}: must be in (0, 1)")


@dataclass(frozen=True)
class RetargetConfig:
    workspace_lo: Vec3 = (0.25, -0.45, 0.03)
    workspace_hi: Vec3 = (0.75, 0.45, 0.65)
    max_step_m: float = 0.02
    max_step_rad: float = 0.12
    max_joint_step: float = 0.05

    def __post_init__(self) -> None:
        if any(lo >= hi for lo, hi in zip(self.workspace_lo, self.workspace_hi, strict=True)):
            raise RecipeError("[retarget] workspace_lo must be below workspace_hi on every axis")
        if min(self.max_step_m, self.max_step_rad, self.max_joint_step) <= 0:
            raise RecipeError("[retarget] step limits must be > 0")


@dataclass(frozen=True)
class ViewConfig:
    image_every: int = 4
    scene_every: int = 1
    shadows: bool = False
    environment: bool = False

    def __post_init__(self) -> None:
        if min(self.image_every, self.scene_every) < 1:
            raise RecipeError("[view] image_every and scene_every must be >= 1 (control steps)")


@dataclass(frozen=True)
class LoopConfig:
    realtime_priority: int = 0

    def __post_init__(self) -> None:
        if self.realtime_priority != 0 and not 2 <= self.realtime_priority <= 98:
            raise RecipeError(f"[loop] realtime_priority = {self.realtime_priority}: must be 0 (off) "
                              "or 2 … 98")


@dataclass(frozen=True)
class TeleopConfig:
    leader: LeaderConfig = field(default_factory=LeaderConfig)
    retarget: RetargetConfig = field(default_factory=RetargetConfig)
    view: ViewConfig = field(default_factory=ViewConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)


def load_teleop_config(path: Path | None = None) -> TeleopConfig:
    """``recipes/teleop.toml`` (or ``path``, which must exist)."""
    return load_settings(TeleopConfig, path or recipes_dir() / TELEOP_TOML, explicit=path is not None)
