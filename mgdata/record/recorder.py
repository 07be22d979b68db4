"""Recorder: turns a running scene into episode frames, labelled and monitored at every control step.

Every demonstration source (planner, GELLO, SO-101) drives the robot the same way::

    rec = Recorder(scene, spec, sink, cameras=rig, success_fn=family_success)
    rec.start()                          # observes s0: L(s0), monitor t = 0, engagement, success
    for action in actions:
        controller.apply(action); controller.step()
        state = rec.record(action)       # frame t = (obs s_t, a_t); then observes s_{t+1}
        if state.violated.any(): ...
    meta = rec.finish(seed=..., draw_index=..., kept=True)   # or rec.discard()

Frame ``t`` pairs the observation *before* acting with the action taken from it (the LeRobot convention):
state, images, labels ``L(s_t)``, the monitor after reading ``L(s_0..s_t)``, engagement (latched), the
success predicate at ``s_t`` and the MuJoCo state ``s_t`` itself (``mgdata.record.physics``), so that
setting frame ``t``'s physics state and applying its action reproduces frame ``t + 1``. Each observation's
deepest contact overlap is measured (:mod:`mgdata.sim.penetration`); the episode's deepest, with its frame
and bodies, goes into its metadata. ``start`` also
hands the sink the compiled scene (MJB). An episode of ``T`` actions has ``T + 1`` frames: the final
observation is stored with the last action repeated (the robot holds its last command). Frames go to the
sink as they are made, so memory stays bounded; nothing is visible in the dataset before ``finish``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

import mgdata
from mgdata.errors import MgdataError
from mgdata.ltl import Monitor, MonitorState, verdict
from mgdata.record.episode import DatasetSchema, EpisodeMeta, EpisodeSink, Frame
from mgdata.record.physics import model_bytes, physics_state, state_size
from mgdata.sim import robot
from mgdata.sim.engagement import EngagementTracker
from mgdata.sim.labelling import Labeller
from mgdata.sim.penetration import NONE, Penetration, deepest_contact
from mgdata.sim.predicates import Contacts
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import Scene
from mgdata.spec import SafetySpec

SuccessFn = Callable[[Scene], bool]


def schema_for(scene: Scene, spec: SafetySpec, cameras: CameraRig | None, fps: int = 20) -> DatasetSchema:
    """The dataset schema matching what a :class:`Recorder` with these arguments produces."""
    size = cameras.size if cameras is not None else 0  # a camera-free dataset has no image size
    return DatasetSchema(fps=fps, cameras=cameras.cameras if cameras is not None else (), image_height=size,
                         image_width=size, propositions=spec.proposition_names,
                         constraints=tuple(c.id for c in spec.constraints),
                         physics_state_size=state_size(scene.model))


class _Observation:
    """Everything measured at one state, waiting for the action taken from it."""

    __slots__ = ("engaged", "images", "labels", "monitor", "physics", "state", "success")

    def __init__(self, state: np.ndarray, images: Mapping[str, np.ndarray], labels: np.ndarray,
                 monitor: MonitorState, engaged: bool, success: bool, physics: np.ndarray) -> None:
        self.state, self.images, self.labels = state, images, labels
        self.monitor, self.engaged, self.success, self.physics = monitor, engaged, success, physics


class Recorder:
    """Labels, monitors and records one episode at a time (see the module docstring).

    Attributes:
        labeller: the spec's labelling function on this scene.
        monitor: the spec's runtime monitor.
        engagement: the first-contact tracker.
    """

    def __init__(self, scene: Scene, spec: SafetySpec, sink: EpisodeSink, cameras: CameraRig | None = None,
                 success_fn: SuccessFn | None = None) -> None:
        self.scene = scene
        self.spec = spec
        self.sink = sink
        self.cameras = cameras
        self.success_fn = success_fn
        self.labeller = Labeller(scene, spec)
        self.monitor = Monitor(spec)
        self.engagement = EngagementTracker(scene)
        self._pending: _Observation | None = None
        self._last_action: np.ndarray | None = None
        self._last_executed: np.ndarray | None = None
        self._n_frames = 0
        self._n_observed = 0
        self.penetration: Penetration = NONE
        """The deepest contact overlap over the episode's observations so far (with its frame)."""

    # -- episode lifecycle -------------------------------------------------------------------------------
    def start(self) -> MonitorState:
        """Begin an episode at the scene's current state (``t = 0``)."""
        if self._pending is not None:
            raise MgdataError("Recorder.start() called while an episode is in progress; "
                              "call finish() or discard() first")
        self.monitor.reset()
        self.engagement.reset()
        self._last_action = self._last_executed = None
        self._n_frames = 0
        self._n_observed = 0
        self.penetration = NONE
        self.sink.set_scene(model_bytes(self.scene.model))
        self._pending = self._observe()
        return self._pending.monitor

    def record(self, action: np.ndarray, executed: np.ndarray | None = None) -> MonitorState:
        """Emit frame ``t`` (observation before ``action`` + ``action``), then observe the new state.

        ``executed``: the command the controller actually ran, where it differs from the recorded action
        (a perturbed demonstration, :mod:`mgdata.engine.perturbation`); default ``action``."""
        if self._pending is None:
            raise MgdataError("Recorder.record() called before start()")
        a = np.asarray(action, dtype=np.float32)
        e = a if executed is None else np.asarray(executed, dtype=np.float32)
        if a.shape != (8,) or e.shape != (8,):
            raise MgdataError(f"action must have shape (8,), got {a.shape} (executed {e.shape})")
        self._emit(self._pending, a, e)
        self._last_action, self._last_executed = a, e
        self._pending = self._observe()
        return self._pending.monitor

    def finish(self, *, seed: int, draw_index: int, kept: bool, success: bool | None = None,
               failure_stage: str | None = None, failure_reason: str | None = None,
               grasp_id: str | None = None, variation: Mapping[str, Any] | None = None,
               source: str = "planner") -> EpisodeMeta:
        """Emit the final observation, commit the episode to the sink and return its metadata.

        ``success`` defaults to the success predicate at the final state.
        """
        if self._pending is None:
            raise MgdataError("Recorder.finish() called before start()")
        final = self._pending
        last = self._last_action if self._last_action is not None else self._hold_action()
        self._emit(final, last, self._last_executed if self._last_executed is not None else last)
        task = self.scene.task
        first = self.first_violation
        meta = EpisodeMeta(
            family=task.family, task_id=task.task_id, condition=task.condition, prompt=task.prompt,
            spec_name=self.spec.name, formulas={c.id: c.formula for c in self.spec.constraints},
            seed=seed, draw_index=draw_index, success=final.success if success is None else success,
            verdict=verdict(self.t_violation, self.t_engage), kept=kept, t_engage=self.t_engage,
            t_violation=first, failure_stage=failure_stage, failure_reason=failure_reason, grasp_id=grasp_id,
            variation=dict(variation or {}), source=source, software_version=mgdata.__version__,
            max_penetration=self.penetration.depth, penetration_step=self.penetration.step,
            penetration_bodies=self.penetration.bodies or None,
        )
        self.sink.end_episode(meta)
        self._pending = None
        return meta

    def discard(self) -> None:
        """Drop the episode in progress; the sink's dataset is unchanged."""
        self.sink.discard_episode()
        self._pending = None

    # -- status ------------------------------------------------------------------------------------------
    @property
    def t(self) -> int:
        """Index of the latest observation (−1 before ``start``)."""
        return self._pending.monitor.t if self._pending is not None else -1

    @property
    def n_frames(self) -> int:
        """Frames already sent to the sink in this episode."""
        return self._n_frames

    @property
    def t_engage(self) -> int | None:
        return self.engagement.t_engage

    @property
    def t_violation(self) -> int | None:
        return self._pending.monitor.t_violation if self._pending is not None else None

    @property
    def first_violation(self) -> dict[str, int | None]:
        """Constraint id -> step of its first violation (``None``: not violated)."""
        firsts = self._pending.monitor.first_violation if self._pending is not None else ()
        ids = self.monitor.constraint_ids
        return dict(zip(ids, firsts or (None,) * len(ids), strict=True))

    @property
    def success(self) -> bool:
        """The success predicate at the latest observation."""
        return bool(self._pending is not None and self._pending.success)

    @property
    def labels(self) -> np.ndarray:
        """The truth of each proposition at the latest observation, bool (n_propositions,), spec order."""
        if self._pending is None:
            raise MgdataError("Recorder.labels read before start()")
        return self._pending.labels

    # -- internals ---------------------------------------------------------------------------------------
    def _observe(self) -> _Observation:
        t = self._n_observed
        self._n_observed += 1
        physics = physics_state(self.scene.model, self.scene.data)
        deepest = deepest_contact(self.scene.model, self.scene.data)
        if deepest.depth > self.penetration.depth:
            self.penetration = dataclasses.replace(deepest, step=t)
        contacts = Contacts(self.scene)
        labels = self.labeller.labels(contacts)
        state = np.empty(8, dtype=np.float32)
        state[:7] = self.scene.arm_q()
        state[7] = self.scene.gripper_opening()
        images = self.cameras.render() if self.cameras is not None else {}
        engaged = self.engagement.update(t, contacts)
        success = bool(self.success_fn(self.scene)) if self.success_fn is not None else False
        return _Observation(state, images, labels, self.monitor.step(labels), engaged, success, physics)

    def _emit(self, obs: _Observation, action: np.ndarray, executed: np.ndarray) -> None:
        self.sink.add_frame(Frame(state=obs.state, action=np.asarray(action, dtype=np.float32),
                                  images=obs.images, labels=obs.labels, dfa_state=obs.monitor.dfa_state,
                                  violated=obs.monitor.violated, engaged=obs.engaged, success=obs.success,
                                  physics_state=obs.physics, executed_action=executed))
        self._n_frames += 1

    def _hold_action(self) -> np.ndarray:
        """The action that holds the current state (for an episode with no actions)."""
        ctrl = self.scene.data.ctrl[robot.arm_actuator_ids(self.scene.model)]
        closed = self.scene.gripper.is_closed(ctrl[7])
        return np.array([*ctrl[:7], 1.0 if closed else 0.0], dtype=np.float32)
