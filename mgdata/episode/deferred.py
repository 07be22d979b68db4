"""Render after the gate: an ``EpisodeSink`` that records frames without images and draws them from each
frame's physics state only when the episode is committed.

Generation runs every attempt with no cameras (plan, execute, label, monitor, gate); only the episodes that
reach ``end_episode`` (the kept ones, and failed ones with ``--keep-failed``) are rendered, from the
recorded per-step MuJoCo states, and handed on to the real sink. The images are byte-identical to rendering
during execution: the controller ends every control step with ``mj_forward``, and restoring a frame's state
(:func:`mgdata.record.physics.set_physics_state`) ends with the same ``mj_forward`` of the same state, so the
rig sees the same positions (tested in ``tests/engine/test_two_pass.py``). Failed attempts, which are
dropped, cost no rendering at all. With a recipe's ``[appearance]`` on, each episode is drawn with its own
appearance (:mod:`mgdata.record.appearance`, draw ``k = 0``), recorded in ``variation.appearance``.

Example::

    sink = DeferredRenderSink(stager, rig)             # rig: a CameraRig of the scene being simulated
    recorder = Recorder(scene, spec, sink, cameras=None)
    ...                                                # frames arrive without images
    recorder.finish(...)                               # renders every frame, then stager.end_episode
"""

from __future__ import annotations

import dataclasses

import mujoco

from mgdata.episode.timing import Timings
from mgdata.errors import DatasetError
from mgdata.record.appearance import episode_appearance
from mgdata.record.episode import EpisodeMeta, EpisodeSink, Frame
from mgdata.record.physics import set_physics_state
from mgdata.sim.appearance_draw import AppearanceSettings
from mgdata.sim.renderer import CameraRig


class DeferredRenderSink:
    """Holds an episode's image-less frames; renders them with ``rig`` and forwards everything to ``sink``
    when the episode ends (see the module docstring).

    Attributes:
        timings: seconds spent rendering (``rendering``) and in the inner sink (``encoding``: encoding the
            videos while frames arrive; ``writing``: its ``end_episode``).
    """

    def __init__(self, sink: EpisodeSink, rig: CameraRig,
                 appearance: AppearanceSettings | None = None) -> None:
        self.sink = sink
        self.rig = rig
        self.appearance = appearance if appearance is not None and appearance.enabled else None
        self.timings = Timings()
        self._data = mujoco.MjData(rig.model)
        self._frames: list[Frame] = []

    def set_scene(self, mjb: bytes) -> None:
        self.sink.set_scene(mjb)

    def add_frame(self, frame: Frame) -> None:
        if frame.physics_state is None:
            raise DatasetError("deferred rendering needs each frame's physics state; this frame has none")
        self._frames.append(frame)

    def end_episode(self, meta: EpisodeMeta) -> None:
        frames, self._frames = self._frames, []
        t, model = self.timings, self.rig.model
        if self.appearance is not None and frames:
            with t.measure("rendering"):
                draw = episode_appearance(self.appearance, model, [f.physics_state for f in frames], meta)
                self.rig.set_appearance(draw)
            meta = dataclasses.replace(meta, variation={**meta.variation, "appearance": draw.record()})
        for frame in frames:
            with t.measure("rendering"):
                set_physics_state(model, self._data, frame.physics_state)
                images = self.rig.render(self._data)
            with t.measure("encoding"):
                self.sink.add_frame(dataclasses.replace(frame, images=images))
        with t.measure("writing"):
            self.sink.end_episode(meta)

    def discard_episode(self) -> None:
        self._frames = []
        self.sink.discard_episode()
