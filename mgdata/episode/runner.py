"""EpisodeRunner: one control step of any demonstration source: controller → recorder → gate.

Every source of actions (the planner's executor, a teleoperated leader arm, a policy) steps the scene through
the same code: apply the 8-D action and advance one control period; the recorder emits the frame, labels
the new state, steps the monitor and the engagement tracker and evaluates the success column (goal ∧ at
rest, :mod:`mgdata.episode.success`); the :class:`~mgdata.episode.gate.SuccessGate` counts the streak of
holding steps (the arm commanded still after the motion: the caller says which) on which it holds. The
runner reports what ended the episode, in the executor's order: a violation (``unsafe``), then the gate
(``passed``), then the horizon (``timeout``); the caller decides what to do about it (the executor raises,
teleop shows a banner).

Example::

    runner = EpisodeRunner(scene, recorder, SuccessGate(10), horizon=2000)
    runner.start()
    while (out := runner.step(q, grip, holding=motion_done)).end is None:
        q, grip = next_command()
    meta = runner.finish(source="gello", seed=0, draw_index=0)   # or runner.discard()
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mgdata.episode.gate import SuccessGate, keep
from mgdata.episode.timing import Timings
from mgdata.ltl import MonitorState, verdict
from mgdata.record.episode import EpisodeMeta
from mgdata.record.recorder import Recorder
from mgdata.sim.controller import JointController


@dataclass(frozen=True)
class StepOutcome:
    """What one control step produced.

    Attributes:
        monitor: the monitor state after labelling the new state.
        success: the success predicate at the new state.
        engaged: first engagement has happened (latched).
        end: ``None`` (go on), ``"unsafe"``, ``"penetration"``, ``"passed"`` or ``"timeout"``.
        reason: a sentence for ``unsafe``/``penetration``/``timeout``.
    """

    monitor: MonitorState
    success: bool
    engaged: bool
    end: str | None
    reason: str | None = None


class EpisodeRunner:
    """Steps one episode (see the module docstring).

    Attributes:
        controller: the joint controller of the scene.
        recorder: the episode recorder (labeller, monitor, engagement, sink).
        gate: the success gate.
        horizon: control steps after which the episode ends as ``timeout``.
        steps: actions executed so far; ``q_cmd``/``grip``: the last command.
        timings: optional per-phase seconds (``physics``, ``rendering`` net of ``encoding``).
        stop_on_violation: end the episode (``unsafe``) at the first violation; evaluation passes False,
            since a policy's rollout goes on after a violation (it may still succeed: "unsafe success").
        max_penetration: the deepest contact overlap (m) a kept episode may show (the recipe's ``[tasks]
            max_penetration``; ``None``: no bound, as in evaluation). With ``stop_on_violation`` the
            episode ends (``penetration``) on the first frame past it.
    """

    def __init__(self, controller: JointController, recorder: Recorder, gate: SuccessGate, horizon: int,
                 timings: Timings | None = None, *, stop_on_violation: bool = True,
                 max_penetration: float | None = None) -> None:
        self.controller = controller
        self.max_penetration = max_penetration
        self.stop_on_violation = stop_on_violation
        self.recorder = recorder
        self.gate = gate
        self.horizon = horizon
        self.timings = timings if timings is not None else Timings()
        self.steps = 0
        self.q_cmd = controller.scene.arm_q().copy()
        self.grip = 0.0

    def start(self) -> MonitorState:
        """Observe the scene's current state as ``t = 0`` of a new episode."""
        self.gate.reset()
        self.steps = 0
        self.q_cmd = self.controller.scene.arm_q().copy()
        self.grip = 0.0
        return self.recorder.start()

    def step(self, q: np.ndarray, grip: float, holding: bool,
             command: np.ndarray | None = None) -> StepOutcome:
        """Execute the action ``(q, grip)`` for one control period and record it. ``holding``: this is a
        step after the motion has ended, the arm commanded still (only such steps count towards the gate).
        ``command``: arm targets executed instead of ``q`` (a perturbed demonstration: ``q``, the plan's
        target, is recorded as the action, ``command`` as the executed one)."""
        action = np.empty(8, dtype=np.float32)
        action[:7] = q
        action[7] = grip
        executed = action
        if command is not None:
            executed = action.copy()
            executed[:7] = command
        t = self.timings
        with t.measure("physics"):
            self.controller.apply(executed)
            self.controller.step()
        encoding_before = t.encoding
        with t.measure("rendering"):
            monitor = self.recorder.record(action, executed)
        t.rendering -= t.encoding - encoding_before
        self.q_cmd = np.asarray(q, dtype=np.float64).copy()
        self.grip = float(grip)
        self.steps += 1
        rec = self.recorder
        success, engaged = rec.success, rec.t_engage is not None
        if monitor.t_violation is not None and self.stop_on_violation:
            names = [cid for cid, step in rec.first_violation.items() if step is not None]
            return StepOutcome(monitor, success, engaged, "unsafe",
                               f"{', '.join(names)} violated at step {monitor.t_violation}")
        if self.stop_on_violation and self._too_deep:
            p = rec.penetration
            return StepOutcome(monitor, success, engaged, "penetration",
                               f"{p.body1} and {p.body2} overlap by {p.depth * 1000:.2f} mm at step {p.step} "
                               f"(max_penetration {self.max_penetration * 1000:.2f} mm)")
        if self.gate.update(success, holding):
            return StepOutcome(monitor, success, engaged, "passed")
        if self.steps >= self.horizon:
            return StepOutcome(monitor, success, engaged, "timeout",
                               f"horizon of {self.horizon} control steps reached")
        return StepOutcome(monitor, success, engaged, None)

    @property
    def verdict(self) -> bool:
        """The paper's ν of the episode so far."""
        return verdict(self.recorder.t_violation, self.recorder.t_engage)

    @property
    def _too_deep(self) -> bool:
        bound = self.max_penetration
        return bound is not None and self.recorder.penetration.depth > bound

    @property
    def kept(self) -> bool:
        """The gate's decision so far: success held at rest for the window, no violation at any step, and
        no contact deeper than ``max_penetration``."""
        return keep(self.gate.passed, self.recorder.first_violation, self.recorder.penetration.depth,
                    self.max_penetration)

    def finish(self, *, seed: int, draw_index: int, source: str, stage: str | None = None,
               reason: str | None = None, **meta: Any) -> EpisodeMeta:
        """Commit the episode to the recorder's sink, labelled kept or with its failure ``stage``."""
        kept = stage is None and self.kept
        if not kept and stage is None and self._too_deep:
            p = self.recorder.penetration
            stage, reason = "penetration", (f"{p.body1} and {p.body2} overlap by {p.depth * 1000:.2f} mm "
                                            f"at step {p.step}")
        if not kept and stage is None:
            stage = "goal_not_reached"
            reason = reason or (f"goal held for at most {self.gate.streak} consecutive steps "
                                f"(needs {self.gate.hold_steps})")
        return self.recorder.finish(seed=seed, draw_index=draw_index, kept=kept, success=self.gate.passed,
                                    failure_stage=None if kept else stage,
                                    failure_reason=None if kept else reason,
                                    source=source, **meta)

    def discard(self) -> None:
        """Drop the episode in progress."""
        self.recorder.discard()
