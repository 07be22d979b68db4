"""The episodes table (``meta/episodes/chunk-*/file-*.parquet``): one row per episode.

Columns follow LeRobot v3.0 (``episode_index``, ``tasks``, ``length``, ``data/*``, ``dataset_from_index``,
``dataset_to_index``, ``videos/<key>/*``, ``stats/<feature>/<stat>``, ``meta/episodes/*``) plus mgdata's own:
the :class:`~mgdata.record.episode.EpisodeMeta` fields (``mgdata/<field>``), each camera's exact pixel
histogram (``mgdata/histogram/<video key>``, 3×256 counts) from which dataset image stats are summed, and,
in a dataset with physics states, the compiled scene the episode ran in (``mgdata/scene``, a scene id of
the scenes files ``meta/scenes/…``, see :mod:`mgdata.record.scenes`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.episode import DatasetSchema, EpisodeMeta
from mgdata.record.metadata import OPTIONAL, PREFIX, meta_fields, meta_from_columns, meta_to_columns
from mgdata.record.stats import STAT_KEYS, FeatureStats

HISTOGRAM_PREFIX = "mgdata/histogram/"
SCENE_COLUMN = "mgdata/scene"


@dataclass(frozen=True)
class VideoSpan:
    """Where one camera of an episode lives: its file and its time range within it (seconds)."""

    ref: layout.FileRef
    from_timestamp: float
    to_timestamp: float


@dataclass(frozen=True)
class EpisodeRecord:
    """One row of the episodes table, typed.

    Attributes:
        index: episode index; ``from_index`` is its first global frame index (``index`` column).
        videos: video key → :class:`VideoSpan`; ``histograms``: video key → (3, 256) pixel counts.
        stats: feature key → its per-episode stats.
        scene: the id of the compiled scene in the scenes files (``None``: no physics states).
    """

    index: int
    length: int
    task: str
    data: layout.FileRef
    from_index: int
    videos: Mapping[str, VideoSpan]
    meta_file: layout.FileRef
    meta: EpisodeMeta
    stats: Mapping[str, FeatureStats]
    histograms: Mapping[str, np.ndarray]
    scene: str | None = None

    @property
    def to_index(self) -> int:
        return self.from_index + self.length


def stats_features(schema: DatasetSchema) -> tuple[tuple[str, bool], ...]:
    """(feature key, is image) for every feature that has stats, in ``info.json`` order."""
    frame = [(c.key, False) for c in layout.frame_columns(schema)]
    videos = [(layout.video_key(cam), True) for cam in schema.cameras]
    index = [(c.key, False) for c in layout.index_columns()]
    return tuple(frame + videos + index)


def _stat_type(stat: str, image: bool) -> pa.DataType:
    if stat == "count":
        return pa.list_(pa.int64())
    return pa.list_(pa.list_(pa.list_(pa.float64()))) if image else pa.list_(pa.float64())


def table_schema(schema: DatasetSchema) -> pa.Schema:
    """The arrow schema of the episodes table for a dataset schema."""
    fields = [
        pa.field("episode_index", pa.int64()), pa.field("tasks", pa.list_(pa.string())),
        pa.field("length", pa.int64()),
        pa.field("data/chunk_index", pa.int64()), pa.field("data/file_index", pa.int64()),
        pa.field("dataset_from_index", pa.int64()), pa.field("dataset_to_index", pa.int64()),
    ]
    for cam in schema.cameras:
        key = layout.video_key(cam)
        fields += [pa.field(f"videos/{key}/chunk_index", pa.int64()),
                   pa.field(f"videos/{key}/file_index", pa.int64()),
                   pa.field(f"videos/{key}/from_timestamp", pa.float64()),
                   pa.field(f"videos/{key}/to_timestamp", pa.float64())]
    for key, image in stats_features(schema):
        fields += [pa.field(f"stats/{key}/{stat}", _stat_type(stat, image)) for stat in STAT_KEYS]
    fields += [pa.field("meta/episodes/chunk_index", pa.int64()),
               pa.field("meta/episodes/file_index", pa.int64())]
    fields += list(meta_fields())
    fields += [pa.field(HISTOGRAM_PREFIX + layout.video_key(cam), pa.list_(pa.int64()))
               for cam in schema.cameras]
    if schema.physics_state_size:
        fields.append(pa.field(SCENE_COLUMN, pa.string()))
    return pa.schema(fields)


def record_to_table(rec: EpisodeRecord, schema: DatasetSchema) -> pa.Table:
    """A one-row table for ``rec``."""
    row: dict[str, Any] = {
        "episode_index": rec.index, "tasks": [rec.task], "length": rec.length,
        "data/chunk_index": rec.data.chunk, "data/file_index": rec.data.file,
        "dataset_from_index": rec.from_index, "dataset_to_index": rec.to_index,
    }
    for key, span in rec.videos.items():
        row.update({f"videos/{key}/chunk_index": span.ref.chunk, f"videos/{key}/file_index": span.ref.file,
                    f"videos/{key}/from_timestamp": span.from_timestamp,
                    f"videos/{key}/to_timestamp": span.to_timestamp})
    for key, _ in stats_features(schema):
        for stat in STAT_KEYS:
            row[f"stats/{key}/{stat}"] = rec.stats[key][stat].tolist()
    row["meta/episodes/chunk_index"] = rec.meta_file.chunk
    row["meta/episodes/file_index"] = rec.meta_file.file
    row.update(meta_to_columns(rec.meta))
    for key, hist in rec.histograms.items():
        row[HISTOGRAM_PREFIX + key] = hist.reshape(-1).tolist()
    if schema.physics_state_size:
        row[SCENE_COLUMN] = rec.scene
    target = table_schema(schema)
    return pa.Table.from_pylist([row], schema=target)


def records_from_table(table: pa.Table, schema: DatasetSchema, where: str) -> list[EpisodeRecord]:
    """Parse every row; a missing column or malformed value raises :class:`DatasetError` naming ``where``."""
    optional = {PREFIX + name for name in OPTIONAL}  # older datasets lack them
    missing = [f.name for f in table_schema(schema)
               if f.name not in table.column_names and f.name not in optional]
    if missing:
        more = " …" if len(missing) > 4 else ""
        raise DatasetError(f"{where}: episodes table lacks columns {missing[:4]}{more}")
    records = []
    for row in table.to_pylist():
        try:
            records.append(_record_from_row(row, schema, where))
        except (TypeError, ValueError, IndexError) as err:
            raise DatasetError(f"{where}: malformed episode row {row.get('episode_index')} ({err})") from err
    return records


def _record_from_row(row: dict[str, Any], schema: DatasetSchema, where: str) -> EpisodeRecord:
    videos = {}
    hists = {}
    for cam in schema.cameras:
        key = layout.video_key(cam)
        ref = layout.FileRef(row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"])
        videos[key] = VideoSpan(ref, row[f"videos/{key}/from_timestamp"], row[f"videos/{key}/to_timestamp"])
        hists[key] = np.asarray(row[HISTOGRAM_PREFIX + key], dtype=np.int64).reshape(3, 256)
    stats = {key: {stat: np.asarray(row[f"stats/{key}/{stat}"]) for stat in STAT_KEYS}
             for key, _ in stats_features(schema)}
    if row["dataset_to_index"] != row["dataset_from_index"] + row["length"]:
        raise ValueError("dataset_to_index != dataset_from_index + length")
    tasks = row["tasks"]
    if not tasks or len(tasks) != 1:
        raise ValueError(f"expected exactly one task, found {tasks}")
    return EpisodeRecord(
        index=row["episode_index"], length=row["length"], task=tasks[0],
        data=layout.FileRef(row["data/chunk_index"], row["data/file_index"]),
        from_index=row["dataset_from_index"], videos=videos,
        meta_file=layout.FileRef(row["meta/episodes/chunk_index"], row["meta/episodes/file_index"]),
        meta=meta_from_columns(row, where), stats=stats, histograms=hists,
        scene=_scene_ref(row[SCENE_COLUMN]) if schema.physics_state_size else None,
    )


def _scene_ref(value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{SCENE_COLUMN} is {value!r}, expected a scene id of {layout.SCENES_DIR}")
    return value
