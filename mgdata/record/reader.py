"""Read an mgdata LeRobot v3.0 dataset without torch: episodes, labels, metadata and decoded frames.

Example::

    reader = DatasetReader(Path("datasets/jar"))
    ep = reader.episode(0)                 # EpisodeData: state, action, safety arrays, meta
    rgb = reader.frames(0, "front")        # (T, H, W, 3) uint8, decoded with PyAV

Unknown, corrupt or other-version datasets raise :class:`~mgdata.errors.DatasetError` naming the file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import FileView
from mgdata.record.episode import EpisodeMeta
from mgdata.record.episodes import EpisodeRecord, records_from_table
from mgdata.record.metafiles import (
    gate_from_info,
    physics_spec_from_info,
    read_info,
    read_tasks,
    schema_from_info,
    spec_from_dict,
    video_settings_from_info,
)
from mgdata.record.scenes import Scenes
from mgdata.record.stats import FeatureStats, stats_from_json
from mgdata.record.video import decode
from mgdata.spec import SafetySpec


def read_parquet(path: Path, columns: list[str] | None = None) -> pa.Table:
    """Read a parquet file; a missing, truncated or corrupt one raises :class:`DatasetError`."""
    try:
        return pq.read_table(path, columns=columns)
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing") from None
    except (OSError, pa.ArrowException) as err:
        raise DatasetError(f"{path}: unreadable parquet ({err})") from err


@dataclass(frozen=True)
class EpisodeData:
    """One episode's per-frame arrays (T frames) and its metadata.

    Attributes:
        state, action: float32 (T, 8).
        labels: bool (T, n_propositions); dfa_state: int16 (T, n_constraints);
        violated: bool (T, n_constraints).
        engaged, success: bool (T,). timestamp: float32 (T,) seconds from the episode start.
        frame_index, global_index: int64 (T,).
        physics_state: float64 (T, n): the MuJoCo state of each frame (``None`` in a dataset without one).
        executed_action: float32 (T, 8): the command the controller ran at each frame, where the dataset
            stores one (perturbed demonstrations; ``None``: the executed command is ``action``).
    """

    index: int
    task: str
    meta: EpisodeMeta
    state: np.ndarray
    action: np.ndarray
    labels: np.ndarray
    dfa_state: np.ndarray
    violated: np.ndarray
    engaged: np.ndarray
    success: np.ndarray
    timestamp: np.ndarray
    frame_index: np.ndarray
    global_index: np.ndarray
    physics_state: np.ndarray | None = None
    executed_action: np.ndarray | None = None

    @property
    def length(self) -> int:
        return len(self.state)


class DatasetReader:
    """Read-only access to a dataset written by :class:`~mgdata.record.writer.DatasetWriter`.

    Attributes:
        root, info (``info.json`` as a dict), schema, video (settings), tasks (task strings by index).
        hold_steps: the gate's success window (``None``: not recorded); kept_only: the dataset promises
        that every episode passed the gate. physics_spec: the ``mjtState`` bits of ``sim.physics_state``
        (``None``: the dataset stores no physics state).
    """

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            raise DatasetError(f"{self.root}: no such dataset folder")
        self.files = FileView(self.root)
        info_path = self.files.path(layout.INFO_PATH)
        self.info: dict[str, Any] = read_info(info_path)
        self.schema = schema_from_info(self.info, str(info_path))
        self.video = video_settings_from_info(self.info, str(info_path))
        self.hold_steps, self.kept_only = gate_from_info(self.info, str(info_path))
        self.physics_spec = physics_spec_from_info(self.info, str(info_path))
        total = int(self.info["total_episodes"])
        self.tasks: list[str] = read_tasks(self.files.path(layout.TASKS_PATH)) if total else []
        self._records: list[EpisodeRecord] = []
        for rel in self.files.glob(layout.EPISODES_DIR + "/chunk-*/file-*.parquet"):
            path = self.files.path(rel)
            self._records += records_from_table(read_parquet(path), self.schema, str(path))
        if [r.index for r in self._records] != list(range(total)):
            found = _summary([r.index for r in self._records])
            raise DatasetError(f"{self.root / layout.EPISODES_DIR}: episode indices {found}, info.json says "
                               f"{total} episodes")
        self._data_cache: tuple[str, pa.Table] | None = None
        self._scenes: Scenes | None = None

    # --- dataset level ------------------------------------------------------------------------------------

    @property
    def num_episodes(self) -> int:
        return len(self._records)

    @property
    def num_frames(self) -> int:
        return int(self.info["total_frames"])

    @property
    def spec(self) -> SafetySpec | None:
        """The safety spec stored in ``info.json`` (``None`` if the writer was given none)."""
        data = self.info["mgdata"].get("spec")
        return spec_from_dict(data, str(self.files.path(layout.INFO_PATH))) if data else None

    def stats(self) -> dict[str, FeatureStats]:
        """``meta/stats.json`` as arrays."""
        path = self.files.path(layout.STATS_PATH)
        try:
            return stats_from_json(json.loads(path.read_text()))
        except FileNotFoundError:
            raise DatasetError(f"{path}: missing") from None
        except (OSError, ValueError, AttributeError) as err:
            raise DatasetError(f"{path}: unreadable ({err})") from err

    def record(self, i: int) -> EpisodeRecord:
        """The episodes-table row of episode ``i`` (file locations, stats, metadata)."""
        if not 0 <= i < len(self._records):
            raise DatasetError(f"{self.root}: no episode {i} (the dataset has {len(self._records)})")
        return self._records[i]

    def records(self) -> list[EpisodeRecord]:
        return list(self._records)

    # --- episode level ------------------------------------------------------------------------------------

    def data_table(self, ref: layout.FileRef) -> pa.Table:
        """A whole data file (the last one read is cached)."""
        rel = layout.data_path(ref)
        if self._data_cache is None or self._data_cache[0] != rel:
            path = self.files.path(rel)
            table = read_parquet(path)
            missing = [c.key for c in layout.all_columns(self.schema) if c.key not in table.column_names]
            if missing:
                raise DatasetError(f"{path}: missing columns {missing}")
            self._data_cache = (rel, table)
        return self._data_cache[1]

    def episode(self, i: int) -> EpisodeData:
        """Episode ``i``'s per-frame arrays and metadata (no video decoding)."""
        rec = self.record(i)
        table = self.data_table(rec.data)
        path = self.files.path(layout.data_path(rec.data))
        index = table.column("index").to_numpy()
        lo = int(np.searchsorted(index, rec.from_index))
        rows = table.slice(lo, rec.length)
        if rows.num_rows != rec.length or not np.array_equal(
                rows.column("index").to_numpy(), np.arange(rec.from_index, rec.to_index)):
            raise DatasetError(f"{path}: rows for episode {i} (index {rec.from_index}..{rec.to_index - 1}) "
                               "are missing or out of order")
        cols = {c.key: c.from_arrow(rows.column(c.key)) for c in layout.all_columns(self.schema)}
        s = self.schema
        empty_p = np.zeros((rec.length, len(s.propositions)), bool)
        empty_c = np.zeros((rec.length, len(s.constraints)), np.int16)
        return EpisodeData(
            index=i, task=rec.task, meta=rec.meta, state=cols[layout.STATE], action=cols[layout.ACTION],
            labels=cols.get(layout.LABELS, empty_p), dfa_state=cols.get(layout.DFA_STATE, empty_c),
            violated=cols.get(layout.VIOLATED, empty_c.astype(bool)), engaged=cols[layout.ENGAGED][:, 0],
            success=cols[layout.SUCCESS][:, 0], timestamp=cols["timestamp"][:, 0],
            frame_index=cols["frame_index"][:, 0], global_index=cols["index"][:, 0],
            physics_state=cols.get(layout.PHYSICS_STATE),
            executed_action=cols.get(layout.EXECUTED_ACTION),
        )

    def scenes(self) -> Scenes:
        """The compiled scenes (``meta/scenes/…``, :mod:`mgdata.record.scenes`; empty in a dataset without
        physics states): their index read once and kept (render, merge and the environment view ask for it
        at every episode); each scene's data is read when asked for."""
        if self._scenes is None:
            self._scenes = Scenes.read(self.files)
        return self._scenes

    def scene_mjb(self, i: int) -> bytes:
        """The compiled MuJoCo scene (MJB bytes) episode ``i`` ran in
        (``mgdata.record.physics.model_from_bytes`` loads it)."""
        rec = self.record(i)
        if rec.scene is None:
            raise DatasetError(f"{self.root}: stores no physics states or scenes (written without a "
                               "simulator)")
        return self.scenes().mjb(rec.scene)

    def video_file(self, i: int, camera: str) -> tuple[Path, int]:
        """(mp4 path, first frame within it) of episode ``i``'s ``camera`` (bare name or video key)."""
        key = camera if camera.startswith(layout.IMAGE_PREFIX) else layout.video_key(camera)
        rec = self.record(i)
        if key not in rec.videos:
            raise DatasetError(f"{self.root}: no camera {camera!r}; cameras are {list(self.schema.cameras)}")
        span = rec.videos[key]
        return self.files.path(layout.video_path(key, span.ref)), round(span.from_timestamp * self.schema.fps)

    def frames(self, i: int, camera: str) -> np.ndarray:
        """Episode ``i``'s frames from ``camera`` as (T, H, W, 3) uint8 RGB, decoded with PyAV."""
        path, start = self.video_file(i, camera)
        return decode(path, start, self.record(i).length, self.schema.fps)


def _summary(values: list[int]) -> str:
    if not values:
        return "none"
    return f"{values[:3]}{'…' if len(values) > 3 else ''} ({len(values)} rows)"
