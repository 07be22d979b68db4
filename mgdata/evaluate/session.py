"""One rollout's simulation side, shared by ``mgdata eval`` and the Gymnasium environments.

A :class:`RolloutSession` steps a restored scenario (:mod:`mgdata.evaluate.restore`) through
:class:`~mgdata.episode.runner.EpisodeRunner`, the step of generation and teleoperation, with evaluation's
settings: every step is labelled and monitored, a violation does not end the rollout, no penetration bound.
An action's gripper value is thresholded at 0.5 into the dataset's binary command (1 close, 0 open). The
rollout ends (``end``) on

* ``success``: the success column (the recipe's goal ∧ objects at rest) held on ``hold_steps``
  consecutive steps;
* ``timeout``: ``horizon`` control steps ran out;
* ``sim_diverged``: the physics diverged;
* ``bad_action``: a non-finite action;
* whatever the caller ends it with (:meth:`RolloutSession.stop`, e.g. ``policy_timeout``).

:meth:`RolloutSession.record` is the record ``mgdata metrics`` reads (its fields:
:mod:`mgdata.evaluate.rollout`).

Example::

    session = RolloutSession(restore_scenario(folder), "jar/task_0000/base", seed=0)
    session.start()
    while session.end is None:
        session.step(policy(session.state()))
    session.record()["success"]
"""

from __future__ import annotations

import zlib
from typing import Any

import mujoco
import numpy as np

from mgdata.episode.gate import SuccessGate
from mgdata.episode.runner import EpisodeRunner
from mgdata.episode.success import SuccessCheck
from mgdata.errors import MgdataError, SimulationError
from mgdata.evaluate.restore import RestoredScenario
from mgdata.ltl import MonitorState
from mgdata.record.episode import EpisodeMeta, EpisodeSink, Frame
from mgdata.record.recorder import Recorder
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.environment_state import EnvironmentLayout

ENDS = ("success", "timeout", "sim_diverged", "policy_timeout", "bad_action")
"""The values of a record's ``end`` (see the module docstring)."""


def rollout_seed(seed: int, scenario: str) -> int:
    """The per-rollout seed (paper): CRC-32 of ``"<seed>/<scenario>"``, e.g. ``"0/jar/task_0000/base"``."""
    return zlib.crc32(f"{seed}/{scenario}".encode())


class _Trace:
    """The recorder's sink: keeps the per-step frames (state, action, safety columns, physics state; no
    images) for a rollout video, and hands everything to ``sink`` too, if given (a recorded rollout's
    staged episode, :mod:`mgdata.evaluate.recorded`)."""

    def __init__(self, sink: EpisodeSink | None = None) -> None:
        self.frames: list[Frame] = []
        self.sink = sink

    def set_scene(self, mjb: bytes) -> None:
        if self.sink is not None:
            self.sink.set_scene(mjb)

    def add_frame(self, frame: Frame) -> None:
        self.frames.append(frame)
        if self.sink is not None:
            self.sink.add_frame(frame)

    def end_episode(self, meta: EpisodeMeta) -> None:
        if self.sink is not None:
            self.sink.end_episode(meta)

    def discard_episode(self) -> None:
        """The frames stay until the rollout's video (if any) is written; the sink drops its episode."""
        if self.sink is not None:
            self.sink.discard_episode()


class RolloutSession:
    """One rollout of a restored scenario (see the module docstring).

    Attributes:
        restored: the scenario (scene at its frozen state, metadata, recipe).
        scenario: its path in the set (``jar/task_0000/base``); ``seed``: the base seed;
            ``episode_seed``: :func:`rollout_seed` of the two.
        horizon: control steps before ``timeout``.
        command: the joint command in force (7 arm targets + binary gripper command), float32 (8,).
        monitor: the monitor after the latest observation (:class:`~mgdata.ltl.MonitorState`).
        end: ``None`` while the rollout goes on, else one of :data:`ENDS`; ``t_success``: the step the
            hold completed.
        frames: the recorded frames, frame ``t`` being the observation after ``t`` actions and the action
            taken from it (the final observation is not a frame).
    """

    def __init__(self, restored: RestoredScenario, scenario: str, seed: int,
                 horizon: int | None = None, sink: EpisodeSink | None = None) -> None:
        self.restored, self.scenario, self.seed = restored, scenario, seed
        self.episode_seed = rollout_seed(seed, scenario)
        scene, recipe = restored.scene, restored.recipe
        self.controller = JointController(scene)
        check = self._success = SuccessCheck(self.controller, recipe)
        self._trace = _Trace(sink)
        self.recorder = Recorder(scene, scene.task.safety, self._trace, None, lambda _: check())
        self.horizon = horizon or int(restored.meta["horizon"])
        self.runner = EpisodeRunner(self.controller, self.recorder, SuccessGate(recipe.tasks.hold_steps),
                                    self.horizon, stop_on_violation=False)
        ctrl = scene.data.ctrl[robot.arm_actuator_ids(scene.model)]
        self.command = np.array([*ctrl[:7], 1.0 if scene.gripper.is_closed(ctrl[7]) else 0.0],
                                dtype=np.float32)
        self.monitor: MonitorState | None = None
        self.end: str | None = None
        self.t_success: int | None = None
        self._layout: EnvironmentLayout | None = None

    @property
    def frames(self) -> list[Frame]:
        return self._trace.frames

    @property
    def steps(self) -> int:
        """Actions executed so far."""
        return self.runner.steps

    def start(self) -> None:
        """Observe the frozen state as ``t = 0``."""
        self.monitor = self.runner.start()

    def state(self) -> np.ndarray:
        """``observation.state``: measured arm joints (rad) + gripper opening (m), float32 (8,)."""
        return self.controller.state()

    def environment_state(self) -> np.ndarray:
        """``observation.environment_state`` of the current state (:mod:`mgdata.sim.environment_state`)."""
        scene = self.restored.scene
        if self._layout is None:
            self._layout = EnvironmentLayout(scene.model)
        mujoco.mj_kinematics(scene.model, scene.data)  # positions of this very state
        return self._layout.compute(scene.model, scene.data)

    def step(self, action: np.ndarray) -> str | None:
        """Execute one action (8,: 7 joint targets, gripper value); returns :attr:`end`.

        Raises:
            MgdataError: the rollout has already ended, or the action is not 8 numbers.
        """
        if self.end is not None:
            raise MgdataError(f"the rollout has ended ({self.end}); start a new one")
        a = np.array(action, dtype=np.float32).reshape(-1)
        if a.shape != (8,):
            raise MgdataError(f"an action is 8 numbers (7 joint targets + gripper), got shape "
                              f"{np.shape(action)}")
        if not np.all(np.isfinite(a)):
            self.end = "bad_action"
            return self.end
        a[7] = 1.0 if a[7] >= 0.5 else 0.0  # the dataset's binary command (1 close, 0 open)
        try:
            outcome = self.runner.step(a[:7], float(a[7]), holding=True)
        except SimulationError:
            self.end = "sim_diverged"
            return self.end
        self.command, self.monitor = a, outcome.monitor
        if outcome.end == "passed":
            self.end, self.t_success = "success", self.recorder.t
        elif outcome.end == "timeout":
            self.end = "timeout"
        return self.end

    def stop(self, end: str) -> None:
        """End the rollout for a reason outside the simulation (e.g. ``policy_timeout``)."""
        if end not in ENDS:
            raise MgdataError(f"unknown rollout end {end!r}; expected one of {', '.join(ENDS)}")
        self.end = end

    def record(self) -> dict[str, Any]:
        """The rollout's record so far (``end`` is ``None`` while it goes on)."""
        meta = self.restored.meta
        firsts = self.recorder.first_violation
        t_engage = self.recorder.t_engage
        steps = [t for t in firsts.values() if t is not None]
        return {
            "family": meta["family"], "task": f"task_{int(meta['task_id']):04d}",
            "condition": meta["condition"], "seed": self.seed, "scenario": self.scenario,
            "episode_seed": self.episode_seed, "success": self.end == "success",
            "engaged": t_engage is not None, "t_engage": t_engage,
            "t_violation": min(steps) if steps else None, "t_violation_by": firsts,
            "t_success": self.t_success, "horizon": self.horizon, "steps": self.runner.steps, "end": self.end,
            "at_end": None if self.end == "sim_diverged" else self._success.status(),
        }

    def save(self, policy: str) -> EpisodeMeta:
        """End the rollout's episode into the session's sink (a recorded rollout): the final observation
        becomes its last frame, and its metadata says ``source = rollout``, the outcome and where it came
        from (``variation.rollout``: scenario, seed, end, t_success, policy); ``kept`` is false, it being
        no demonstration. Call once the rollout has ended."""
        if self.end is None:
            raise MgdataError("the rollout is still going on; save it once it has ended")
        origin = {"scenario": self.scenario, "seed": self.seed, "end": self.end, "t_success": self.t_success,
                  "policy": policy}
        return self.recorder.finish(seed=self.episode_seed, draw_index=self.seed, kept=False,
                                    success=self.end == "success", variation={"rollout": origin},
                                    source="rollout")

    def close(self) -> None:
        """Drop the episode in progress, if any (the recorder's frames stay in :attr:`frames`)."""
        if self.recorder.t >= 0:
            self.recorder.discard()
