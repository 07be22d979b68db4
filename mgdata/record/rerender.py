"""``mgdata render``: a new dataset with other cameras, image size or codec, drawn from a dataset's own
physics states, without re-planning or re-simulating.

Every frame of the source stores the MuJoCo state it was observed in (``sim.physics_state``) and every
episode names its compiled scene (:mod:`mgdata.record.scenes`), so each frame is restored
(:func:`~mgdata.record.physics.set_physics_state`) and drawn with the camera rig of ``mgdata.sim``. Everything
else is copied: state, action, the safety columns, the physics states, the scenes, the episode metadata and
the gate's promises (``hold_steps``, ``kept_only``), the generator identity and the attempt count. Only the
videos and their statistics are new. This is what a VLA fine-tuning at 224² needs from a 256² dataset, and
what LIBERO and robomimic users do with their states files.

The new dataset is built in ``<out>.partial`` and renamed to ``out`` when every episode is in, so a folder
named ``out`` is always complete; running the same command again after an interruption continues the
partial one (each episode is committed whole).

With ``appearance = K`` each source episode is rendered K times, with appearance draws ``k = 0 … K-1``
(:mod:`mgdata.record.appearance`; the family recipe's ``[appearance]`` settings if it enables them, else
their documented defaults): new episode ``i`` is source episode ``i // K`` in draw ``i % K``, its
``variation.appearance`` records the draw, and the physics states, actions and labels are the source's,
bit for bit. Data augmentation at render cost only. The recorded attempt count is multiplied by K (each
render of an attempt counts as one), so the yield stays the source's.

Example::

    job = RenderJob(Path("datasets/jar"), Path("datasets/jar_224"), size=224, cameras=("front", "wrist"))
    summary = rerender(job)
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import mujoco

from mgdata.errors import DatasetError, MgdataError, OutputError
from mgdata.lock import output_lock
from mgdata.record import layout
from mgdata.record.appearance import episode_appearance
from mgdata.record.episode import DatasetSchema, Frame
from mgdata.record.integrity import check_intact
from mgdata.record.metafiles import read_info
from mgdata.record.physics import STATE_SPEC, model_from_bytes, set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.record.video import VideoSettings
from mgdata.record.writer import DatasetWriter
from mgdata.sim.appearance_draw import AppearanceSettings
from mgdata.sim.config import load_sim_config
from mgdata.sim.renderer import MAX_SIZE, CameraRig
from mgdata.tasks.recipe import load_recipe

MAX_APPEARANCE = 100
"""Most appearance draws ``mgdata render --appearance`` makes per episode."""


@dataclass(frozen=True)
class RenderJob:
    """What to re-render.

    Attributes:
        source: the dataset to read (it must store physics states).
        out: the new dataset's folder (must not exist).
        size: image side in pixels (``None``: the source's).
        cameras: camera names, in output order (``None``: the source's).
        codec: video codec (``None``: the source's, with its settings).
        appearance: appearance draws per episode (0: the scenes as stored).
        appearance_seed: mixed into every draw's seed (another K draws of the same episodes).
    """

    source: Path
    out: Path
    size: int | None = None
    cameras: tuple[str, ...] | None = None
    codec: str | None = None
    appearance: int = 0
    appearance_seed: int = 0


@dataclass(frozen=True)
class RenderSummary:
    """What a re-render did: episodes and frames written by this run, the dataset's totals, seconds."""

    out: Path
    episodes: int
    frames: int
    total_episodes: int
    wall: float


def partial_path(out: Path) -> Path:
    """Where the new dataset is built until it is complete."""
    return out.with_name(out.name + ".partial")


def _check(job: RenderJob, reader: DatasetReader) -> tuple[DatasetSchema, VideoSettings]:
    """The new dataset's schema and video settings, or one error saying what is wrong."""
    src = reader.schema
    if not src.physics_state_size or reader.physics_spec is None:
        raise DatasetError(f"{job.source}: stores no physics states (written without a simulator), so it "
                           "cannot be re-rendered")
    if reader.physics_spec != STATE_SPEC:
        raise DatasetError(f"{job.source}: physics states of mjtState spec {reader.physics_spec}, this "
                           f"mgdata restores spec {STATE_SPEC}")
    if not reader.num_episodes:
        raise DatasetError(f"{job.source}: the dataset has no episodes to render")
    size = src.image_height if job.size is None else job.size
    if not 8 <= size <= MAX_SIZE:
        raise DatasetError(f"--size {size}: expected an image side in pixels from 8 to {MAX_SIZE}")
    cameras = src.cameras if job.cameras is None else job.cameras
    if not cameras or len(set(cameras)) != len(cameras):
        raise DatasetError(f"--cameras {','.join(cameras)}: expected one or more distinct camera names")
    model = _model(reader.scene_mjb(0), job.source)
    known = [model.camera(i).name for i in range(model.ncam)]
    unknown = [c for c in cameras if c not in known]
    if unknown:
        raise DatasetError(f"unknown camera(s) {', '.join(unknown)}; the dataset's scenes have cameras "
                           f"{', '.join(known)}")
    if not 0 <= job.appearance <= MAX_APPEARANCE:
        raise DatasetError(f"--appearance {job.appearance}: expected 0 (none) to {MAX_APPEARANCE} draws per "
                           "episode")
    video = reader.video if job.codec in (None, reader.video.codec) else \
        VideoSettings(codec=job.codec, gop=reader.video.gop)
    return replace(src, cameras=tuple(cameras), image_height=size, image_width=size), video


def _origin(job: RenderJob, schema: DatasetSchema, video: VideoSettings,
            appearance: AppearanceSettings | None) -> dict[str, Any]:
    """The ``mgdata.rendered_from`` record of the new dataset (also how a partial one is recognised)."""
    origin = {"source": str(Path(job.source).resolve()), "cameras": list(schema.cameras),
              "size": schema.image_height, "codec": video.codec}
    if appearance is not None:
        origin["appearance"] = {"draws": job.appearance, "seed": job.appearance_seed, **appearance.to_info()}
    return origin


def appearance_settings(reader: DatasetReader) -> AppearanceSettings:
    """The family recipe's ``[appearance]`` if it enables it, else the defaults (enabled)."""
    try:
        recipe = load_recipe(reader.record(0).meta.family)
    except MgdataError:  # the family's recipe is not installed here: the documented defaults
        recipe = None
    if recipe is not None and recipe.appearance.enabled:
        return recipe.appearance
    return replace(AppearanceSettings(), enabled=True)


def _open(job: RenderJob, reader: DatasetReader, schema: DatasetSchema,
          video: VideoSettings, appearance: AppearanceSettings | None) -> DatasetWriter:
    """Continue the partial dataset of the same job, or start a new one."""
    part = partial_path(job.out)
    origin = _origin(job, schema, video, appearance)
    if (part / layout.INFO_PATH).exists():
        if read_info(part / layout.INFO_PATH)["mgdata"].get("rendered_from") == origin:
            return DatasetWriter.open(part, schema)
        raise OutputError(f"{part}: left by a render with other settings; delete it or repeat that command")
    if part.exists() and any(p.name != layout.WORK_DIR for p in part.iterdir()):
        raise OutputError(f"{part}: exists and is not a dataset being rendered; delete it first")
    writer = DatasetWriter.create_like(part, reader, schema=schema, video=video,
                                       mgdata={"rendered_from": origin})
    if writer.video != video:
        writer.close()
        raise DatasetError(f"video settings {video} do not survive info.json")
    return writer


def _model(mjb: bytes, source: Path) -> mujoco.MjModel:
    try:
        return model_from_bytes(mjb)
    except Exception as err:  # MuJoCo raises ValueError (other version) or its own error types
        raise DatasetError(f"{source}: a stored scene does not load in MuJoCo {mujoco.__version__} "
                           f"({err})") from None


class _Rigs:
    """The camera rig of the scene in use (a new GL context when the scene changes)."""

    def __init__(self, cameras: tuple[str, ...], size: int) -> None:
        self.cameras, self.size = cameras, size
        self.config = load_sim_config().render
        self._scene: str | None = None
        self.rig: CameraRig | None = None
        self.data: mujoco.MjData | None = None

    def get(self, scene: str, mjb: bytes, source: Path) -> tuple[CameraRig, mujoco.MjData]:
        if scene != self._scene or self.rig is None or self.data is None:
            self.close()
            model = _model(mjb, source)
            self.rig = CameraRig.of_model(model, self.cameras, self.size, self.config)
            self.data, self._scene = self.rig.data, scene
        return self.rig, self.data

    def close(self) -> None:
        if self.rig is not None:
            self.rig.close()
        self.rig, self.data, self._scene = None, None, None


def rerender(job: RenderJob, on_episode: Callable[[int, int], None] | None = None) -> RenderSummary:
    """Write the re-rendered dataset (module docstring); ``on_episode(done, total)`` after each episode.

    Raises:
        DatasetError: the source is missing, corrupt, stores no physics states, or a camera is unknown.
        OutputError: ``out`` exists already.
    """
    out = Path(job.out)
    with output_lock(out):  # one render per --out (its .partial is also the writer's)
        return _rerender(job, out, on_episode)


def _rerender(job: RenderJob, out: Path, on_episode: Callable[[int, int], None] | None) -> RenderSummary:
    if out.exists():
        raise OutputError(f"--out {out}: already exists; choose a new folder")
    check_intact(Path(job.source), "nothing was rendered")
    reader = DatasetReader(Path(job.source))
    schema, video = _check(job, reader)
    appearance = appearance_settings(reader) if job.appearance else None
    start = time.perf_counter()
    writer = _open(job, reader, schema, video, appearance)
    rigs = _Rigs(schema.cameras, schema.image_height)
    per = max(job.appearance, 1)
    total = reader.num_episodes * per
    first, frames = writer.num_episodes, 0
    try:
        writer.record_attempts((reader.info["mgdata"].get("attempts") or 0) * per)
        if on_episode is not None:
            on_episode(first, total)
        for i in range(first, total):
            look = None if appearance is None else (appearance, i % per, job.appearance_seed)
            frames += _render_episode(reader, i // per, writer, rigs, look)
            if on_episode is not None:
                on_episode(i + 1, total)
    finally:
        rigs.close()
        writer.close()
    os.replace(partial_path(out), out)
    return RenderSummary(out, total - first, frames, total, time.perf_counter() - start)


def _render_episode(reader: DatasetReader, e: int, writer: DatasetWriter, rigs: _Rigs,
                    look: tuple[AppearanceSettings, int, int] | None = None) -> int:
    """Render and commit episode ``e`` of ``reader`` (``look``: appearance settings, draw ``k`` and user
    seed); returns its frame count."""
    rec, ep = reader.record(e), reader.episode(e)
    assert rec.scene is not None and ep.physics_state is not None  # checked by _check for the dataset
    mjb = reader.scene_mjb(e)
    rig, data = rigs.get(rec.scene, mjb, reader.root)
    writer.set_scene(mjb)
    meta = ep.meta
    if look is not None:
        settings, k, seed = look
        draw = episode_appearance(settings, rig.model, list(ep.physics_state), meta, k, seed)
        rig.set_appearance(draw)
        meta = replace(meta, variation={**meta.variation, "appearance": {**draw.record(), "seed": seed}})
    else:
        rig.set_appearance(None)
    try:
        for t in range(ep.length):
            set_physics_state(rig.model, data, ep.physics_state[t])
            writer.add_frame(Frame(state=ep.state[t], action=ep.action[t], images=rig.render(data),
                                   labels=ep.labels[t], dfa_state=ep.dfa_state[t], violated=ep.violated[t],
                                   engaged=bool(ep.engaged[t]), success=bool(ep.success[t]),
                                   physics_state=ep.physics_state[t],
                                   executed_action=None if ep.executed_action is None
                                   else ep.executed_action[t]))
        writer.end_episode(meta)
    except BaseException:
        writer.discard_episode()
        raise
    return ep.length
