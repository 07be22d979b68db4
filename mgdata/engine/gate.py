"""The keep/discard gate and the failure stages every rejected attempt is filed under.

An attempt is **kept** iff the family's goal predicate held for ``hold_steps`` (10) consecutive control steps
and the safety verdict ν is 1 (the paper's engagement-gated verdict). The executor ends an attempt as soon as
the gate passes, as an evaluation rollout would, and ends it early on the first violation (stage ``unsafe``).
"""

from __future__ import annotations

from dataclasses import dataclass

STAGES: dict[str, str] = {
    "no_grasp": "no grasp of the target is reachable from the start state",
    "ik_fail": "no inverse-kinematics solution for a segment target",
    "plan_fail": "the free-space planner found no collision-free path",
    "retime_fail": "time-parameterisation of a path failed",
    "collision_recheck": "the retimed trajectory collides on a dense re-check",
    "path_discontinuity": "a Cartesian segment needed a joint-space jump",
    "target_fail": "a runtime target could not be resolved from the live state",
    "unsafe": "the safety monitor reported a violation",
    "sim_diverged": "the physics diverged (NaN or runaway accelerations)",
    "timeout": "the attempt ran past the family's step horizon",
    "goal_not_reached": "all segments ran but the goal did not hold for the gate's window",
}
"""Failure stage -> meaning; the summary counts attempts per stage in this order."""


class AttemptFailed(Exception):
    """Raised inside the executor to end an attempt: ``stage`` (a key of :data:`STAGES`) and ``reason``."""

    def __init__(self, stage: str, reason: str, segment: str | None = None) -> None:
        if stage not in STAGES:
            raise ValueError(f"unknown failure stage {stage!r}; known: {', '.join(STAGES)}")
        super().__init__(f"{stage}: {reason}")
        self.stage = stage
        self.reason = reason
        self.segment = segment


@dataclass
class SuccessGate:
    """Counts consecutive steps on which the goal holds; ``passed`` latches once the streak reaches
    ``hold_steps``.

    Example::

        gate = SuccessGate(hold_steps=10)
        for ok in goal_per_step:
            if gate.update(ok):
                break
    """

    hold_steps: int = 10
    streak: int = 0
    passed: bool = False
    passed_at: int | None = None
    steps: int = 0

    def __post_init__(self) -> None:
        if self.hold_steps < 1:
            raise ValueError(f"hold_steps must be >= 1, got {self.hold_steps}")

    def update(self, goal_holds: bool) -> bool:
        """Feed one control step's goal predicate; returns ``passed``."""
        self.streak = self.streak + 1 if goal_holds else 0
        if not self.passed and self.streak >= self.hold_steps:
            self.passed, self.passed_at = True, self.steps
        self.steps += 1
        return self.passed

    def reset(self) -> None:
        self.streak, self.passed, self.passed_at, self.steps = 0, False, None, 0


def keep(gate_passed: bool, verdict: bool) -> bool:
    """The gate's decision: goal held for the window and ν = 1."""
    return gate_passed and verdict
