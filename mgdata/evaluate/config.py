"""EvalConfig: the tunables of ``mgdata eval`` and ``mgdata serve``, loaded from ``recipes/eval.toml``.

Example::

    config = load_eval_config()
    config.client.chunk_steps   # 8
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mgdata.errors import RecipeError
from mgdata.paths import recipes_dir
from mgdata.settings import load_settings

EVAL_TOML = "eval.toml"


@dataclass(frozen=True)
class ClientConfig:
    """The evaluation client: ``chunk_steps`` actions executed per query; timeouts in seconds."""

    chunk_steps: int = 8
    timeout_s: float = 30.0
    connect_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        if self.chunk_steps < 1:
            raise RecipeError(f"[client] chunk_steps must be >= 1, got {self.chunk_steps}")
        if self.timeout_s <= 0 or self.connect_timeout_s <= 0:
            raise RecipeError("[client] timeouts must be positive")


@dataclass(frozen=True)
class RandomConfig:
    """``mgdata serve random``: chunk length, per-step joint-target change (rad), gripper flip probability."""

    chunk: int = 16
    joint_step: float = 0.05
    gripper_flip: float = 0.05

    def __post_init__(self) -> None:
        if self.chunk < 1 or self.joint_step < 0 or not 0 <= self.gripper_flip <= 1:
            raise RecipeError("[random] needs chunk >= 1, joint_step >= 0 and 0 <= gripper_flip <= 1")


@dataclass(frozen=True)
class ServeConfig:
    """``mgdata serve hold`` / ``replay``: actions per chunk."""

    chunk: int = 16

    def __post_init__(self) -> None:
        if self.chunk < 1:
            raise RecipeError(f"[serve] chunk must be >= 1, got {self.chunk}")


@dataclass(frozen=True)
class EvalConfig:
    client: ClientConfig = field(default_factory=ClientConfig)
    random: RandomConfig = field(default_factory=RandomConfig)
    serve: ServeConfig = field(default_factory=ServeConfig)


def load_eval_config(path: Path | None = None) -> EvalConfig:
    """``recipes/eval.toml`` (or ``path``); a missing default file means all defaults."""
    file = Path(path) if path is not None else recipes_dir() / EVAL_TOML
    return load_settings(EvalConfig, file, explicit=path is not None)
