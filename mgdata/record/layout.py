"""The LeRobot v3.0 on-disk layout: path templates, feature keys and the per-frame column schema.

Writer, reader, validator and exports all follow this one description (as LeRobot's own ``info.json``
does): file paths come from the templates below with a chunk and file index, and every per-frame column
is a :class:`Column` derived from the :class:`~mgdata.record.episode.DatasetSchema`.

Storage rule (as in LeRobot): a feature of shape ``(1,)`` is a scalar parquet column, a feature of shape
``(n,)`` a ``fixed_size_list<dtype>[n]`` column. Safety features of width 0 (no propositions) are omitted.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.record.episode import DatasetSchema

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000
DATA_FILE_MB = 100
VIDEO_FILE_MB = 200
# Each appended episode rewrites (remuxes) the current video file, and LeRobot 0.4.4 matches decoded frame
# times in float32 with a 1e-4 s tolerance (float32 steps exceed it past 1024 s into a file). So mgdata
# also starts a new video file after this many seconds (1200 frames, ~6 jar demos at 20 Hz): at 300 s the
# main process's appends cost 12 s of a 2-worker 40-demo run, at 60 s 8 s.
VIDEO_FILE_SECONDS = 60.0
# Appending rewrites the current data file and episodes file (parquet cannot be appended in place), so a
# commit costs as much as those files hold: mgdata also starts new ones after this many episodes, which keeps
# every commit's cost bounded whatever the dataset's size (benchmarks/bench_append.py: the commit at episode
# 1,000 costs what the one at episode 1 does).
EPISODES_PER_FILE = 20
# The compiled scenes are chunked too, for the same reason: appending a scene rewrites the current scenes
# file. Its rows are zstd frames, which the writer holds and copies as they are, so the new scene's part of
# a commit (its XOR delta, its frame, the rewrite) is ~16-20 ms whatever the scene count, at 20 scenes per
# file (~0.9 MB of deltas) (benchmarks/bench_append.py --scenes 40: 85 ms before frames, when every held row
# was decompressed and compressed again at each rewrite).
SCENES_PER_FILE = 20

INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"
# The dataset card the Hugging Face Hub shows (mgdata/record/card.py): derived, so not in the checksums.
CARD_PATH = "README.md"
# Datasets written before chunked scenes hold every scene in this one file (still read; a resumed one keeps
# it as it is and adds new scenes in SCENES_DIR's files).
LEGACY_SCENES_PATH = "meta/scenes.parquet"
EPISODES_DIR = "meta/episodes"
SCENES_DIR = "meta/scenes"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
EPISODES_PATH = EPISODES_DIR + "/" + CHUNK_FILE + ".parquet"
SCENES_PATH = SCENES_DIR + "/" + CHUNK_FILE + ".parquet"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
# A corrections run's ledger (mgdata/generate/correction_report.py): every failed rollout it tried. Written
# after the episodes, so not in the checksums; a copy of the dataset (render, validate --repair) keeps it.
CORRECTIONS_PATH = "meta/mgdata_corrections.json"
# mgdata's private work area inside a dataset (staged episodes, pending commits); empty after close().
WORK_DIR = ".mgdata"

STATE = "observation.state"
ACTION = "action"
IMAGE_PREFIX = "observation.images."
LABELS = "safety.labels"
DFA_STATE = "safety.dfa_state"
VIOLATED = "safety.violated"
ENGAGED = "safety.engaged"
SUCCESS = "safety.success"
SAFETY_VECTORS: tuple[str, ...] = (LABELS, DFA_STATE, VIOLATED)  # per constraint/proposition, per frame
PHYSICS_STATE = "sim.physics_state"
EXECUTED_ACTION = "sim.executed_action"
INDEX_COLUMNS: tuple[str, ...] = ("timestamp", "frame_index", "episode_index", "index", "task_index")


def video_key(camera: str) -> str:
    """``"front"`` → ``"observation.images.front"``."""
    return IMAGE_PREFIX + camera


def camera_name(key: str) -> str:
    """``"observation.images.front"`` → ``"front"``."""
    return key[len(IMAGE_PREFIX):] if key.startswith(IMAGE_PREFIX) else key


@dataclass(frozen=True, order=True)
class FileRef:
    """A (chunk, file) pair; files roll over to the next chunk every ``chunks_size`` files."""

    chunk: int = 0
    file: int = 0

    def next(self, chunks_size: int = CHUNKS_SIZE) -> FileRef:
        if self.file + 1 >= chunks_size:
            return FileRef(self.chunk + 1, 0)
        return FileRef(self.chunk, self.file + 1)


def data_path(ref: FileRef) -> str:
    return DATA_PATH.format(chunk_index=ref.chunk, file_index=ref.file)


def video_path(key: str, ref: FileRef) -> str:
    return VIDEO_PATH.format(video_key=key, chunk_index=ref.chunk, file_index=ref.file)


def episodes_path(ref: FileRef) -> str:
    return EPISODES_PATH.format(chunk_index=ref.chunk, file_index=ref.file)


def scenes_path(ref: FileRef) -> str:
    return SCENES_PATH.format(chunk_index=ref.chunk, file_index=ref.file)


@dataclass(frozen=True)
class Column:
    """One per-frame feature stored in the data parquet.

    Attributes:
        key: LeRobot feature key (``"observation.state"``).
        dtype: LeRobot/numpy dtype name (``"float32"``, ``"float64"``, ``"int16"``, ``"bool"``, ``"int64"``).
        width: number of values per frame (the feature's shape is ``(width,)``).
        names: per-value names, or ``None``.
    """

    key: str
    dtype: str
    width: int
    names: tuple[str, ...] | None = None

    @property
    def arrow_type(self) -> pa.DataType:
        base = pa.from_numpy_dtype(np.dtype(self.dtype))
        return base if self.width == 1 else pa.list_(base, self.width)

    def to_arrow(self, values: np.ndarray) -> pa.Array:
        """(T, width) values → the parquet column (scalar when width is 1)."""
        flat = np.ascontiguousarray(values, dtype=self.dtype).reshape(-1)
        arr = pa.array(flat, type=pa.from_numpy_dtype(np.dtype(self.dtype)))
        return arr if self.width == 1 else pa.FixedSizeListArray.from_arrays(arr, self.width)

    def from_arrow(self, column: pa.ChunkedArray | pa.Array) -> np.ndarray:
        """The parquet column → (T, width) values."""
        if isinstance(column, pa.ChunkedArray):
            column = column.combine_chunks()
        if self.width != 1:
            column = column.flatten()
        flat = column.to_numpy(zero_copy_only=False).astype(self.dtype, copy=False)
        return flat.reshape(-1, self.width)

    def feature(self) -> dict:
        """The ``info.json`` feature entry."""
        return {"dtype": self.dtype, "shape": [self.width], "names": list(self.names) if self.names else None}


def frame_columns(schema: DatasetSchema) -> tuple[Column, ...]:
    """The per-frame features a recorder supplies, in storage order (index columns excluded)."""
    cols = [
        Column(STATE, "float32", len(schema.state_names), schema.state_names),
        Column(ACTION, "float32", len(schema.action_names), schema.action_names),
    ]
    if schema.propositions:
        cols.append(Column(LABELS, "bool", len(schema.propositions), schema.propositions))
    if schema.constraints:
        cols.append(Column(DFA_STATE, "int16", len(schema.constraints), schema.constraints))
        cols.append(Column(VIOLATED, "bool", len(schema.constraints), schema.constraints))
    cols.append(Column(ENGAGED, "bool", 1))
    cols.append(Column(SUCCESS, "bool", 1))
    if schema.physics_state_size:
        cols.append(Column(PHYSICS_STATE, "float64", schema.physics_state_size))
    if schema.executed_action:
        cols.append(Column(EXECUTED_ACTION, "float32", len(schema.action_names), schema.action_names))
    return tuple(cols)


def index_columns() -> tuple[Column, ...]:
    """LeRobot's default per-frame features, appended by the writer."""
    return (
        Column("timestamp", "float32", 1),
        Column("frame_index", "int64", 1),
        Column("episode_index", "int64", 1),
        Column("index", "int64", 1),
        Column("task_index", "int64", 1),
    )


def all_columns(schema: DatasetSchema) -> tuple[Column, ...]:
    return frame_columns(schema) + index_columns()


def data_arrow_schema(schema: DatasetSchema) -> pa.Schema:
    return pa.schema([pa.field(c.key, c.arrow_type) for c in all_columns(schema)])


def write_data_file(table: pa.Table, path: Path) -> None:
    """Write a data parquet: pyarrow's defaults (dictionary, snappy), except ``sim.physics_state``, which is
    stored byte-stream-split and zstd-compressed (parquet-native, any reader decodes it): float64 MuJoCo
    states are noise to a dictionary, and this stores a jar frame's 78 values in ~506 B instead of ~735 B."""
    leaves = {f.name: f"{f.name}.list.element" if pa.types.is_fixed_size_list(f.type) else f.name
              for f in table.schema}
    if PHYSICS_STATE not in leaves:
        pq.write_table(table, path)
        return
    physics = leaves.pop(PHYSICS_STATE)
    pq.write_table(table, path, use_dictionary=list(leaves.values()), use_byte_stream_split=[physics],
                   compression={**dict.fromkeys(leaves.values(), "snappy"), physics: "zstd"})


def timestamps(length: int, fps: int) -> np.ndarray:
    """LeRobot's per-frame ``timestamp``: ``frame_index / fps`` as float32."""
    return (np.arange(length, dtype=np.float64) / fps).astype(np.float32)
