"""The episode record: what every demonstration source (planner, GELLO, SO-101) hands to a dataset sink.

This is the contract between the recorder (``mgdata.record.recorder``) and the writers: a
:class:`DatasetSchema` fixed per dataset, a stream of :class:`Frame` per control step, and one
:class:`EpisodeMeta` when the episode ends. A sink stores an episode entirely or not at all.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

STATE_NAMES: tuple[str, ...] = (*(f"joint{i}" for i in range(1, 8)), "gripper_opening")
ACTION_NAMES: tuple[str, ...] = (*(f"joint{i}_target" for i in range(1, 8)), "gripper_command")


@dataclass(frozen=True)
class DatasetSchema:
    """Everything about a dataset's features that is fixed before the first frame.

    ``cameras`` are bare names (``"front"``); the LeRobot key is ``observation.images.<camera>``.
    ``propositions`` and ``constraints`` give the column order of the safety features.
    ``physics_state_size`` is the width of the per-frame MuJoCo state (``mgdata.record.physics``; the same
    for every task of a dataset); 0 for a dataset without simulator state (synthetic data).
    ``executed_action``: the dataset stores each frame's executed command beside its recorded action
    (``sim.executed_action``: demonstrations with perturbed execution, :mod:`mgdata.tasks.recovery`).
    """

    fps: int
    cameras: tuple[str, ...]
    image_height: int
    image_width: int
    propositions: tuple[str, ...]
    constraints: tuple[str, ...]
    robot_type: str = "franka_panda"
    state_names: tuple[str, ...] = STATE_NAMES
    action_names: tuple[str, ...] = ACTION_NAMES
    physics_state_size: int = 0
    executed_action: bool = False


@dataclass(frozen=True)
class Frame:
    """One control step.

    Attributes:
        state: float32 (8,): measured arm joints (rad) + gripper opening (m).
        action: float32 (8,): commanded arm joint targets (rad) + gripper command (1 close, 0 open).
        images: camera name -> uint8 (H, W, 3) RGB.
        labels: bool (n_propositions,): truth of each proposition, in schema order.
        dfa_state: int16 (n_constraints,): each constraint's DFA state after this step.
        violated: bool (n_constraints,): latched violation flag of each constraint.
        engaged: whether first engagement has happened at or before this step (latched).
        success: whether the family's success predicate holds at this step (not latched).
        physics_state: float64 (physics_state_size,): the MuJoCo state this step's observation was taken
            from (``mgdata.record.physics.STATE_SPEC`` layout), or ``None`` without a simulator.
        executed_action: float32 (8,): the command the controller ran (``None``: ``action`` itself); it
            differs from ``action`` only in a perturbed demonstration, whose ``action`` is the plan's target.
    """

    state: np.ndarray
    action: np.ndarray
    images: Mapping[str, np.ndarray]
    labels: np.ndarray
    dfa_state: np.ndarray
    violated: np.ndarray
    engaged: bool
    success: bool
    physics_state: np.ndarray | None = None
    executed_action: np.ndarray | None = None


@dataclass(frozen=True)
class EpisodeMeta:
    """Per-episode facts, stored in the episodes table so they are readable without decoding video.

    Step indices (``t_engage``, ``t_violation``) count control steps from 0; ``None`` means never.
    ``verdict`` is the paper's ν: True unless the first violation happens at or after first engagement.
    ``kept`` says whether the gate accepted the episode (negatives kept with ``--keep-failed`` are False).
    ``max_penetration`` is the deepest contact overlap over the episode's frames (m,
    :mod:`mgdata.sim.penetration`), found at frame ``penetration_step`` between ``penetration_bodies``
    (``"a|b"``); all three ``None`` where nothing was measured (a dataset older than the figure).
    """

    family: str
    task_id: int
    condition: str
    prompt: str
    spec_name: str
    formulas: Mapping[str, str]
    seed: int
    draw_index: int
    success: bool
    verdict: bool
    kept: bool
    t_engage: int | None
    t_violation: Mapping[str, int | None]
    failure_stage: str | None = None
    failure_reason: str | None = None
    grasp_id: str | None = None
    variation: Mapping[str, Any] = field(default_factory=dict)
    source: str = "planner"
    software_version: str = ""
    max_penetration: float | None = None
    penetration_step: int | None = None
    penetration_bodies: str | None = None


class EpisodeSink(Protocol):
    """Where the recorder sends an episode. Nothing is visible in the dataset until ``end_episode``."""

    def set_scene(self, mjb: bytes) -> None:
        """Attach the compiled MuJoCo model (MJB bytes) the episode in progress runs in."""

    def add_frame(self, frame: Frame) -> None:
        """Append one control step to the episode in progress (starting one if none is)."""

    def end_episode(self, meta: EpisodeMeta) -> None:
        """Commit the episode in progress atomically."""

    def discard_episode(self) -> None:
        """Drop the episode in progress; the dataset is unchanged."""


class MemorySink:
    """Keeps whole episodes (and the scene each ran in) in memory: for tests and short interactive runs."""

    def __init__(self) -> None:
        self.episodes: list[tuple[list[Frame], EpisodeMeta]] = []
        self.scenes: list[bytes | None] = []
        self._frames: list[Frame] = []
        self._scene: bytes | None = None

    def set_scene(self, mjb: bytes) -> None:
        self._scene = mjb

    def add_frame(self, frame: Frame) -> None:
        self._frames.append(frame)

    def end_episode(self, meta: EpisodeMeta) -> None:
        self.episodes.append((self._frames, meta))
        self.scenes.append(self._scene)
        self._frames, self._scene = [], None

    def discard_episode(self) -> None:
        self._frames, self._scene = [], None
