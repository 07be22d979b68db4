"""Staged episodes: one finished episode in its own folder, encoded but not yet part of any dataset.

A worker process records into an :class:`EpisodeStager` (an ``EpisodeSink``) without touching the dataset;
the main process later appends the staged folders in draw order with
:meth:`mgdata.record.writer.DatasetWriter.append_staged`, which copies the video packets (no re-encode).
The single-process writer stages each episode the same way, so both paths write the same bytes.

Folder contents: ``<video key>.mp4`` per camera (frames 0…T-1, starting with a keyframe),
``frames.parquet`` (the per-frame features), ``scene.mjb`` (the compiled MuJoCo model the episode ran in,
when the schema has physics states: this is how the scene travels from a worker process to the writer),
``episode.json`` (length, task, metadata, pixel histograms, the schema and video settings it was made
with). The folder appears atomically (rename of ``<path>.partial``) when the episode ends.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import fsync_file
from mgdata.record.episode import DatasetSchema, EpisodeMeta, Frame
from mgdata.record.metadata import check_meta, meta_from_dict, meta_to_dict
from mgdata.record.stats import rgb_histogram
from mgdata.record.video import VideoEncoder, VideoSettings

STAGED_FORMAT = 1
EPISODE_JSON = "episode.json"
FRAMES_PARQUET = "frames.parquet"
SCENE_MJB = "scene.mjb"


def schema_from_dict(data: dict) -> DatasetSchema:
    return DatasetSchema(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


@dataclass(frozen=True)
class StagedEpisode:
    """A staged episode folder, loaded (videos stay on disk)."""

    path: Path
    length: int
    task: str
    meta: EpisodeMeta
    histograms: dict[str, np.ndarray]
    schema: DatasetSchema
    video: VideoSettings

    @classmethod
    def load(cls, path: Path) -> StagedEpisode:
        file = path / EPISODE_JSON
        try:
            data = json.loads(file.read_text())
        except (OSError, ValueError) as err:
            raise DatasetError(f"{file}: not a staged episode ({err})") from err
        if data.get("format") != STAGED_FORMAT:
            raise DatasetError(f"{file}: staged-episode format {data.get('format')!r}, expected "
                               f"{STAGED_FORMAT}")
        try:
            hists = {k: np.asarray(v, dtype=np.int64).reshape(3, 256) for k, v in data["histograms"].items()}
            staged = cls(path, int(data["length"]), str(data["task"]),
                         meta_from_dict(data["meta"], str(file)), hists, schema_from_dict(data["schema"]),
                         VideoSettings(**data["video"]))
        except (KeyError, TypeError, ValueError) as err:
            raise DatasetError(f"{file}: malformed staged episode ({err})") from err
        if staged.scene_file is not None and not staged.scene_file.is_file():
            raise DatasetError(f"{staged.scene_file}: missing (a staged episode with physics states carries "
                               "its compiled scene)")
        return staged

    def video_file(self, key: str) -> Path:
        return self.path / f"{key}.mp4"

    @property
    def scene_file(self) -> Path | None:
        """The compiled scene (MJB) the episode ran in; ``None`` for a schema without physics states."""
        return self.path / SCENE_MJB if self.schema.physics_state_size else None

    def frames_table(self) -> pa.Table:
        file = self.path / FRAMES_PARQUET
        try:
            table = pq.read_table(file)
        except (OSError, pa.ArrowException) as err:
            raise DatasetError(f"{file}: unreadable ({err})") from err
        if table.num_rows != self.length:
            raise DatasetError(f"{file}: {table.num_rows} rows, episode.json says {self.length}")
        return table


class EpisodeStager:
    """An ``EpisodeSink`` that writes one episode into a staged folder at ``path``.

    Frames are checked against the schema and each camera is encoded while frames arrive; nothing but the
    small numeric columns is kept in memory. ``end_episode`` makes ``path`` appear (atomically);
    ``discard_episode`` drops the episode so another attempt can be recorded into the same stager.

    Example::

        stager = EpisodeStager(tmp / "draw-000007", schema)
        for frame in frames:
            stager.add_frame(frame)
        stager.end_episode(meta)        # tmp/draw-000007 now exists
        writer.append_staged(tmp / "draw-000007")
    """

    def __init__(self, path: Path, schema: DatasetSchema, video: VideoSettings | None = None) -> None:
        self.path = Path(path)
        self.schema = schema
        self.video = video or VideoSettings()
        self._columns = layout.frame_columns(schema)
        self._partial = self.path.with_name(self.path.name + ".partial")
        self._encoders: dict[str, VideoEncoder] = {}
        self._rows: dict[str, list[np.ndarray]] = {}
        self._hists: dict[str, np.ndarray] = {}
        self._scene: bytes | None = None
        self._length = 0
        self.done = False

    def set_scene(self, mjb: bytes) -> None:
        if not self.schema.physics_state_size:
            raise DatasetError(f"{self.path}: the dataset schema has no physics state, so no scene is stored")
        self._scene = bytes(mjb)

    def add_frame(self, frame: Frame) -> None:
        if self.done:
            raise DatasetError(f"{self.path}: this stager already holds a finished episode")
        values = self._check(frame)
        if self._length == 0:
            self._start()
        for col in self._columns:
            self._rows[col.key].append(values[col.key])
        for cam in self.schema.cameras:
            key = layout.video_key(cam)
            image = np.ascontiguousarray(frame.images[cam])
            self._encoders[key].add(image)
            self._hists[key] += rgb_histogram(image)
        self._length += 1

    def end_episode(self, meta: EpisodeMeta) -> None:
        if self._length == 0:
            raise DatasetError(f"{self.path}: cannot end an episode without frames")
        check_meta(meta, self.schema.constraints)
        if self.schema.physics_state_size and self._scene is None:
            raise DatasetError(f"{self.path}: an episode with physics states needs its compiled scene "
                               "(set_scene before end_episode)")
        if self.path.exists():
            raise DatasetError(f"{self.path}: a staged episode already exists there")
        for enc in self._encoders.values():
            enc.close()
        arrays = [col.to_arrow(np.stack(self._rows[col.key])) for col in self._columns]
        table = pa.Table.from_arrays(arrays, names=[c.key for c in self._columns])
        pq.write_table(table, self._partial / FRAMES_PARQUET)
        if self._scene is not None:
            (self._partial / SCENE_MJB).write_bytes(self._scene)
        doc = {
            "format": STAGED_FORMAT, "length": self._length, "task": meta.prompt, "meta": meta_to_dict(meta),
            "histograms": {k: h.tolist() for k, h in self._hists.items()},
            "schema": asdict(self.schema), "video": asdict(self.video),
        }
        (self._partial / EPISODE_JSON).write_text(json.dumps(doc))
        for file in self._partial.iterdir():
            fsync_file(file)
        os.replace(self._partial, self.path)
        self._reset()
        self.done = True

    def discard_episode(self) -> None:
        for enc in self._encoders.values():
            enc.abort()
        shutil.rmtree(self._partial, ignore_errors=True)
        self._reset()

    def _start(self) -> None:
        shutil.rmtree(self._partial, ignore_errors=True)
        self._partial.mkdir(parents=True)
        s = self.schema
        for cam in s.cameras:
            key = layout.video_key(cam)
            self._encoders[key] = VideoEncoder(self._partial / f"{key}.mp4", s.image_width, s.image_height,
                                               s.fps, self.video)
            self._hists[key] = np.zeros((3, 256), np.int64)
        self._rows = {c.key: [] for c in self._columns}

    def _reset(self) -> None:
        self._encoders, self._rows, self._hists, self._length, self._scene = {}, {}, {}, 0, None

    def _check(self, frame: Frame) -> dict[str, np.ndarray]:
        """The frame's numeric values by feature key, validated against the schema."""
        s = self.schema
        raw = {layout.STATE: frame.state, layout.ACTION: frame.action, layout.LABELS: frame.labels,
               layout.DFA_STATE: frame.dfa_state, layout.VIOLATED: frame.violated,
               layout.ENGAGED: np.asarray([frame.engaged]), layout.SUCCESS: np.asarray([frame.success]),
               layout.PHYSICS_STATE: frame.physics_state,
               layout.EXECUTED_ACTION: frame.action if frame.executed_action is None
               else frame.executed_action}
        out = {}
        for col in self._columns:
            if raw[col.key] is None:
                raise DatasetError(f"frame {self._length}: no {col.key} (the dataset schema has "
                                   f"{col.width} values per frame)")
            value = np.asarray(raw[col.key])
            where = f"frame {self._length}: {col.key}"
            if value.shape != (col.width,):
                raise DatasetError(f"{where} has shape {value.shape}, expected ({col.width},)")
            if col.dtype.startswith("float") and not np.all(np.isfinite(value)):
                raise DatasetError(f"{where} has non-finite values {value.tolist()}")
            if col.dtype == "int16" and (value.min() < -(2**15) or value.max() >= 2**15):
                raise DatasetError(f"{where} values {value.tolist()} do not fit int16")
            out[col.key] = value.astype(col.dtype)
        if set(frame.images) != set(s.cameras):
            raise DatasetError(f"frame {self._length}: images for cameras {sorted(frame.images)}, expected "
                               f"{list(s.cameras)}")
        for cam in s.cameras:
            img = frame.images[cam]
            if not (isinstance(img, np.ndarray) and img.dtype == np.uint8
                    and img.shape == (s.image_height, s.image_width, 3)):
                got = f"{getattr(img, 'dtype', type(img).__name__)} {getattr(img, 'shape', '')}"
                raise DatasetError(f"frame {self._length}: image {cam!r} is {got}, expected uint8 "
                                   f"({s.image_height}, {s.image_width}, 3)")
        return out
