"""The keep/discard gate and the failure stages every rejected attempt is filed under.

An attempt is **kept** iff

* **success held at rest after the motion**: on ``hold_steps`` (10) consecutive control steps *after the
  last motion segment has finished* (only steps of the final holds, the arm commanded still, count), the
  family's goal predicate held **and** the goal's objects were at rest (:class:`RestCheck`: linear and
  angular speed below the recipe's ``[tasks] rest_linear_speed`` / ``rest_angular_speed``), and
* **no violation at any step**: every constraint's ``t_violation`` is ``None``. This is stronger than the
  paper's verdict ν = 1, which excuses violations before first engagement; a training demonstration must
  never show one. ν is still computed and stored as the paper defines it.

The per-step success column of a dataset (``Frame.success``) is "goal predicate ∧ at rest" at that step, so
a kept episode ends with ``hold_steps`` frames whose success is true and whose actions are all equal (the
hold): a validator can audit the gate from the data alone. The executor ends an attempt as soon as the gate
passes, and ends it at the first violation (stage ``unsafe``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

STAGES: dict[str, str] = {
    "no_grasp": "no grasp of the target is reachable from the start state",
    "ik_fail": "no inverse-kinematics solution for a segment target",
    "plan_fail": "the free-space planner found no collision-free path",
    "retime_fail": "time-parameterisation of a path failed",
    "collision_recheck": "the retimed trajectory collides on a dense re-check",
    "path_discontinuity": "a Cartesian segment needed a joint-space jump",
    "target_fail": "a runtime target could not be resolved from the live state",
    "guarded_no_contact": "a guarded move reached its distance limit without its contact condition",
    "guarded_stalled": "a guarded move stopped advancing before its contact condition held",
    "unsafe": "the safety monitor reported a violation",
    "sim_diverged": "the physics diverged (NaN or runaway accelerations)",
    "timeout": "the attempt ran past the family's step horizon",
    "goal_not_reached": "all segments ran but the goal did not hold at rest for the gate's window",
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
    """Counts consecutive holding steps on which the success column (goal ∧ at rest) holds; ``passed``
    latches once the streak reaches ``hold_steps``. A step that is not a holding step (the arm still moving
    or about to move again) breaks the streak.

    Example::

        gate = SuccessGate(hold_steps=10)
        for ok, holding in zip(success_per_step, holding_per_step):
            if gate.update(ok, holding):
                break
    """

    hold_steps: int = 10
    streak: int = 0
    best: int = 0
    passed: bool = False
    passed_at: int | None = None
    steps: int = 0

    def __post_init__(self) -> None:
        if self.hold_steps < 1:
            raise ValueError(f"hold_steps must be >= 1, got {self.hold_steps}")

    def update(self, success: bool, holding: bool = True) -> bool:
        """Feed one control step: its success column and whether it was a holding step; returns
        ``passed``."""
        self.streak = self.streak + 1 if success and holding else 0
        self.best = max(self.best, self.streak)
        if not self.passed and self.streak >= self.hold_steps:
            self.passed, self.passed_at = True, self.steps
        self.steps += 1
        return self.passed

    def reset(self) -> None:
        self.streak, self.best, self.passed, self.passed_at, self.steps = 0, 0, False, None, 0


class RestCheck:
    """Are the named bodies at rest? Speeds of each body's frame origin, world frame, from ``data.cvel``
    (``mj_objectVelocity``): linear ≤ ``linear`` (m/s) and angular ≤ ``angular`` (rad/s) for every body.

    Example::

        rest = RestCheck(model, [model.body("jar").id], linear=0.005, angular=0.05)
        rest.at_rest(data)
    """

    def __init__(self, model: mujoco.MjModel, bodies: Sequence[int], *, linear: float,
                 angular: float) -> None:
        self.model, self.bodies = model, tuple(int(b) for b in bodies)
        self.linear, self.angular = float(linear), float(angular)
        self._v = np.zeros(6)

    def speeds(self, data: mujoco.MjData) -> tuple[float, float]:
        """The largest linear (m/s) and angular (rad/s) speed over the bodies."""
        lin = ang = 0.0
        for b in self.bodies:
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, b, self._v, 0)
            ang = max(ang, float(np.linalg.norm(self._v[:3])))
            lin = max(lin, float(np.linalg.norm(self._v[3:])))
        return lin, ang

    def at_rest(self, data: mujoco.MjData) -> bool:
        lin, ang = self.speeds(data)
        return lin <= self.linear and ang <= self.angular


def keep(gate_passed: bool, t_violation: Mapping[str, int | None]) -> bool:
    """The gate's decision: success held at rest after the motion, and no constraint was ever violated
    (not even before engagement, which ν = 1 would excuse)."""
    return gate_passed and all(t is None for t in t_violation.values())
