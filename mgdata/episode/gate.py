"""The keep/discard gate and the failure stages every rejected attempt is filed under.

An attempt is **kept** iff

* **success held at rest after the motion**: on ``hold_steps`` (10) consecutive control steps *after the
  last motion segment has finished* (only steps of the final holds, the arm commanded still, count), the
  family's goal predicate held **and** the goal's objects were at rest (:class:`RestCheck`: linear and
  angular speed below the recipe's ``[tasks] rest_linear_speed`` / ``rest_angular_speed`` at every physics
  substep of the step), and
* **no violation at any step**: every constraint's ``t_violation`` is ``None``. This is stronger than the
  paper's verdict ν = 1, which excuses violations before first engagement; a training demonstration must
  never show one. ν is still computed and stored as the paper defines it, and
* **no interpenetration**: no contact of any frame sinks deeper than the recipe's ``[tasks]
  max_penetration`` (:mod:`mgdata.sim.penetration`; the episode records its deepest, stage ``penetration``).

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
    "restart_refused": "a restart state fails a restart rule (objects moving, unsafe, hand busy, infeasible)",
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
    "penetration": "a contact sank deeper than the recipe's max_penetration (objects pressed into others)",
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
    """Are the named bodies at rest, over the whole last control period? Linear speed of each body's centre
    of mass ≤ ``linear`` (m/s) and angular speed ≤ ``angular`` (rad/s), world frame (``mj_objectVelocity``
    of the body), for every body, **at every physics substep** of the period, not only at the
    control sample: a body rocking between 20 Hz samples is not at rest.

    The controller calls :meth:`reset` when a control period begins and :meth:`observe` after each physics
    step (:meth:`mgdata.sim.controller.JointController.watch`); :meth:`at_rest` judges the peak since
    then together with the current state. MuJoCo integrates positions from those very velocities, so a
    body that passes moves at most ``linear`` × period between frames, which ``mgdata validate`` audits
    from the stored states. Without substep observations (the initial-state gate's settle) only the
    current state is judged.

    Example::

        rest = RestCheck(model, [model.body("jar").id], linear=0.005, angular=0.05)
        controller.watch(rest)
        controller.step()
        rest.at_rest(data)
    """

    def __init__(self, model: mujoco.MjModel, bodies: Sequence[int], *, linear: float,
                 angular: float) -> None:
        self.model, self.bodies = model, tuple(int(b) for b in bodies)
        self.linear, self.angular = float(linear), float(angular)
        self._ids = np.array(self.bodies, dtype=np.int64)
        self._roots = model.body_rootid[self._ids]
        self.reset()

    def speeds(self, data: mujoco.MjData) -> tuple[float, float]:
        """The largest linear (m/s) and angular (rad/s) speed over the bodies in ``data``'s current
        velocities (``data.cvel``, moved from the subtree's centre of mass to each body's, as
        ``mj_objectVelocity`` does)."""
        if not self.bodies:
            return 0.0, 0.0
        cvel = data.cvel[self._ids]
        r = data.xipos[self._ids] - data.subtree_com[self._roots]
        w = cvel[:, :3]
        # r × w written out: np.cross costs ~20 µs per call, and this runs at every physics substep
        cross = np.stack([r[:, 1] * w[:, 2] - r[:, 2] * w[:, 1], r[:, 2] * w[:, 0] - r[:, 0] * w[:, 2],
                          r[:, 0] * w[:, 1] - r[:, 1] * w[:, 0]], axis=1)
        lin = cvel[:, 3:] - cross
        return (float(np.sqrt(np.max(np.einsum("ij,ij->i", lin, lin)))),
                float(np.sqrt(np.max(np.einsum("ij,ij->i", cvel[:, :3], cvel[:, :3])))))

    def reset(self) -> None:
        """Forget the peak (a control period begins)."""
        self.peak_linear = self.peak_angular = 0.0

    def observe(self, data: mujoco.MjData) -> None:
        """Take the velocities of the physics step just taken into the peak."""
        lin, ang = self.speeds(data)
        self.peak_linear, self.peak_angular = max(self.peak_linear, lin), max(self.peak_angular, ang)

    def peak_speeds(self, data: mujoco.MjData) -> tuple[float, float]:
        """The largest speeds since :meth:`reset`, the current state's included."""
        lin, ang = self.speeds(data)
        return max(self.peak_linear, lin), max(self.peak_angular, ang)

    def at_rest(self, data: mujoco.MjData) -> bool:
        lin, ang = self.peak_speeds(data)
        return lin <= self.linear and ang <= self.angular


def keep(gate_passed: bool, t_violation: Mapping[str, int | None], penetration: float = 0.0,
         max_penetration: float | None = None) -> bool:
    """The gate's decision: success held at rest after the motion, no constraint was ever violated (not
    even before engagement, which ν = 1 would excuse), and no contact of any frame sank deeper than
    ``max_penetration`` (m; ``None``: no bound)."""
    return (gate_passed and all(t is None for t in t_violation.values())
            and (max_penetration is None or penetration <= max_penetration))
