"""The LeRobot v3.0 dataset writer (pyarrow + PyAV, no torch).

Episodes are appended whole: each is staged (encoded while its frames arrive, see
:mod:`mgdata.record.staging`), then :meth:`DatasetWriter.append_staged` copies its video packets into each
camera's current mp4, appends its rows to the current data file, adds its row to the episodes table and
rewrites tasks, stats, ``info.json`` and the dataset card ``README.md`` (:mod:`mgdata.record.card`; and, the
first time a base task appears, adds its compiled scene to the last scenes file, :mod:`mgdata.record.scenes`)
— all in one
:class:`~mgdata.record.commit.Transaction`, so a killed process leaves the dataset exactly as it was after
the last complete episode. Files roll over at LeRobot's size limits (data 100 MB, video 200 MB), for video
after ``video_file_seconds``, for data and episodes files after ``episodes_per_file`` episodes and for
scenes files after ``scenes_per_file`` scenes, so a commit costs the same at episode 1 and episode 10,000
(dataset stats are merged incrementally too, :func:`~mgdata.record.stats.merge_stats`), and the writer
holds only the scenes it appends against (:class:`~mgdata.record.scenes.SceneAppender`).

Example::

    with DatasetWriter.create(root, schema, spec=spec) as writer:
        for frame in frames:
            writer.add_frame(frame)
        writer.end_episode(meta)
    writer = DatasetWriter.open(root)          # resume: continues appending
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Mapping
from pathlib import Path
from types import TracebackType

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.errors import DatasetError
from mgdata.interrupts import sigint_deferred
from mgdata.record import layout
from mgdata.record.card import EpisodeTally, render_card
from mgdata.record.commit import Transaction, WriterLock, recover, sha256_file, work_dir
from mgdata.record.episode import DatasetSchema, EpisodeMeta, Frame
from mgdata.record.episodes import (
    EpisodeRecord,
    VideoSpan,
    record_to_table,
    stats_features,
    table_schema,
)
from mgdata.record.integrity import check_intact
from mgdata.record.metafiles import (
    build_info,
    dump_json,
    read_info,
    schema_from_info,
    video_settings_from_info,
    write_tasks,
)
from mgdata.record.reader import DatasetReader, read_parquet
from mgdata.record.scenes import SceneAppender
from mgdata.record.staging import EpisodeStager, StagedEpisode
from mgdata.record.stats import FeatureStats, image_stats, merge_stats, numeric_stats, stats_to_json
from mgdata.record.video import VideoSettings, remux
from mgdata.spec import SafetySpec

_MB = 1024 * 1024
# info.json's ``mgdata`` keys a copy of a dataset carries: those of the run that made it (a copy of the same
# episodes: render, repair, the merge of a run's shards), then the physical promises every copy keeps.
RUN_IDENTITY = ("generator", "corrections")
CARRIED_KEYS = ("physics_gate", "recovery")


class DatasetWriter:
    """Appends episodes to a LeRobot v3.0 dataset; also an ``EpisodeSink`` for a recorder.

    Attributes:
        root: the dataset folder.
        schema: its :class:`DatasetSchema`; ``video``: its :class:`VideoSettings`.
    """

    def __init__(self, root: Path, info: dict, lock: WriterLock) -> None:
        self.root = root
        self._info = info
        self._lock: WriterLock | None = lock
        self.schema = schema_from_info(info, str(root / layout.INFO_PATH))
        self.video = video_settings_from_info(info, str(root / layout.INFO_PATH))
        self._frame_cols = layout.frame_columns(self.schema)
        self._records: list[EpisodeRecord] = []
        self._tasks: list[str] = []
        self._numeric: dict[str, FeatureStats] = {}  # dataset stats of the numeric features (merged)
        self._hist_sum = {layout.video_key(c): np.zeros((3, 256), np.int64) for c in self.schema.cameras}
        self._episodes_table: pa.Table | None = None
        self._tally = EpisodeTally()  # what the card says about the episodes
        self._scenes = SceneAppender(int(info["mgdata"].get("scenes_per_file") or layout.SCENES_PER_FILE),
                                     int(info["chunks_size"]))
        self._stager: EpisodeStager | None = None
        self._stale = False  # a commit failed half-way: memory no longer matches the disk

    # --- construction ------------------------------------------------------------------------------------

    @classmethod
    def create(cls, root: Path, schema: DatasetSchema, *, codec: str = "h264", crf: int | None = None,
               preset: str | None = None, gop: int = 10, spec: SafetySpec | None = None,
               chunks_size: int = layout.CHUNKS_SIZE, data_file_mb: int = layout.DATA_FILE_MB,
               video_file_mb: int = layout.VIDEO_FILE_MB,
               video_file_seconds: float = layout.VIDEO_FILE_SECONDS, hold_steps: int | None = None,
               kept_only: bool = False, mgdata: dict | None = None,
               episodes_per_file: int | None = layout.EPISODES_PER_FILE,
               scenes_per_file: int = layout.SCENES_PER_FILE) -> DatasetWriter:
        """Start a new dataset in ``root`` (absent or empty). ``spec`` is stored in ``info.json``, and so
        are the promises ``mgdata validate`` audits: ``hold_steps`` (a successful episode ends with the goal
        held on its last ``hold_steps`` frames) and ``kept_only`` (every episode passed the gate; a
        ``generate`` output, whose negatives go to ``<out>_failed``), and the extra keys of ``mgdata`` (in
        its ``mgdata`` block; e.g. the generator's inputs digest).

        A folder holding only the work area of a ``create`` that was killed before its first commit counts
        as empty.
        """
        root = Path(root)
        if root.exists() and any(p.name != layout.WORK_DIR for p in root.iterdir()):
            raise DatasetError(f"{root}: already exists and is not empty (use DatasetWriter.open to resume)")
        if spec is not None:
            if spec.proposition_names != schema.propositions:
                raise DatasetError(f"spec propositions {list(spec.proposition_names)} differ from the "
                                   f"schema's {list(schema.propositions)}")
            if tuple(c.id for c in spec.constraints) != schema.constraints:
                raise DatasetError(f"spec constraints {[c.id for c in spec.constraints]} differ from the "
                                   f"schema's {list(schema.constraints)}")
        if hold_steps is not None and hold_steps < 1:
            raise DatasetError(f"hold_steps must be >= 1, got {hold_steps}")
        if scenes_per_file < 1:
            raise DatasetError(f"scenes_per_file must be >= 1, got {scenes_per_file}")
        video = VideoSettings(codec=codec, crf=crf, preset=preset, gop=gop)
        info = build_info(schema, video, spec, chunks_size=chunks_size, data_file_mb=data_file_mb,
                          video_file_mb=video_file_mb, video_file_seconds=video_file_seconds,
                          hold_steps=hold_steps, kept_only=kept_only, episodes_per_file=episodes_per_file,
                          scenes_per_file=scenes_per_file)
        info["mgdata"].update({k: v for k, v in (mgdata or {}).items() if k not in info["mgdata"]})
        root.mkdir(parents=True, exist_ok=True)
        lock = WriterLock(root)
        try:
            if recover(root):  # a killed create had committed after all
                raise DatasetError(f"{root}: already holds a dataset (use DatasetWriter.open to resume)")
            shutil.rmtree(work_dir(root) / "staging", ignore_errors=True)
            writer = cls(root, info, lock)
            if writer.schema != schema:
                raise DatasetError(f"schema does not survive info.json: {schema} vs {writer.schema}")
            tx = Transaction(root)
            tx.path(layout.INFO_PATH).write_text(dump_json(info))
            _write_card(tx, info, [], writer._tally)
            tx.commit()
        except BaseException:
            lock.release()
            raise
        return writer

    @classmethod
    def create_like(cls, root: Path, source: DatasetReader, *, schema: DatasetSchema | None = None,
                    video: VideoSettings | None = None, mgdata: dict | None = None,
                    identity: bool = True) -> DatasetWriter:
        """Start a new dataset in ``root`` written as ``source`` was: its video settings, spec, file sizes,
        the gate's promises (its physical bounds included) and, with ``identity``, the run that made it (its
        generator's inputs digest, a corrections run's settings and ledger), after the keys of ``mgdata``;
        ``schema`` and ``video`` replace ``source``'s (a re-render).
        What ``merge``, ``render`` and ``validate --repair`` write."""
        info, mg = source.info, source.info["mgdata"]
        video = video or source.video
        extra = dict(mgdata or {})
        for key in (RUN_IDENTITY if identity else ()) + CARRIED_KEYS:
            if mg.get(key) is not None:
                extra[key] = mg[key]
        writer = cls.create(
            root, schema or source.schema, codec=video.codec, crf=video.crf, preset=video.preset,
            gop=video.gop, spec=source.spec, chunks_size=int(info["chunks_size"]),
            data_file_mb=int(info["data_files_size_in_mb"]),
            video_file_mb=int(info["video_files_size_in_mb"]),
            video_file_seconds=float(mg["video_file_seconds"]), hold_steps=source.hold_steps,
            kept_only=source.kept_only, mgdata=extra, episodes_per_file=mg.get("episodes_per_file"),
            scenes_per_file=mg.get("scenes_per_file") or layout.SCENES_PER_FILE)
        report = source.root / layout.CORRECTIONS_PATH
        if identity and report.exists():
            shutil.copyfile(report, writer.root / layout.CORRECTIONS_PATH)
        return writer

    @classmethod
    def open(cls, root: Path, schema: DatasetSchema | None = None) -> DatasetWriter:
        """Resume an existing dataset: finish or drop an interrupted commit, check every file against its
        recorded checksum (damage: :class:`DatasetError`, nothing written), drop unfinished staged work,
        check ``schema`` (if given) matches, and continue appending after the last complete episode."""
        root = Path(root)
        if not (root / layout.INFO_PATH).exists() and not (root / layout.WORK_DIR).exists():
            raise DatasetError(f"{root}: no dataset here ({layout.INFO_PATH} missing)")
        lock = WriterLock(root)
        try:
            recover(root)
            check_intact(root)  # never append to damaged files (mgdata/record/integrity.py)
            shutil.rmtree(work_dir(root) / "staging", ignore_errors=True)
            info = read_info(root / layout.INFO_PATH)
            writer = cls(root, info, lock)
            if schema is not None and schema != writer.schema:
                raise DatasetError(f"{root}: dataset schema {writer.schema} differs from the requested "
                                   f"{schema}")
            writer._load()
        except BaseException:
            lock.release()
            raise
        return writer

    @classmethod
    def open_or_create(cls, root: Path, schema: DatasetSchema, **create_args: object) -> DatasetWriter:
        """:meth:`open` the dataset at ``root`` if one was ever committed there, else :meth:`create` it
        (also after a ``create`` killed before its first commit); ``create_args`` go to :meth:`create`."""
        root = Path(root)
        committed = (root / layout.INFO_PATH).exists() or (work_dir(root) / "pending" / "COMMIT").exists()
        return cls.open(root, schema) if committed else cls.create(root, schema, **create_args)

    def _load(self) -> None:
        """Rebuild the in-memory state (records, tasks, stats inputs) from the committed files."""
        reader = DatasetReader(self.root)
        self._records, self._tasks = reader.records(), list(reader.tasks)
        self._tally = EpisodeTally.of(r.meta for r in self._records)
        self._scenes = SceneAppender.load(reader.scenes(), self._scenes.per_file, self._scenes.chunks_size)
        if self._records:
            last = read_parquet(self.root / layout.episodes_path(self._records[-1].meta_file))
            self._episodes_table = last.cast(table_schema(self.schema))  # canonical list field names
        for rec in self._records:
            for key, hist in rec.histograms.items():
                self._hist_sum[key] += hist
            self._numeric = _merged(self._numeric, rec.stats, self.schema)

    # --- queries -----------------------------------------------------------------------------------------

    @property
    def num_episodes(self) -> int:
        return len(self._records)

    @property
    def num_frames(self) -> int:
        return int(self._info["total_frames"])

    def episodes_meta(self) -> list[EpisodeMeta]:
        """The metadata of every committed episode, in episode order."""
        return [r.meta for r in self._records]

    def stager(self, path: Path) -> EpisodeStager:
        """An :class:`EpisodeStager` with this dataset's schema and video settings (e.g. for a worker)."""
        return EpisodeStager(Path(path), self.schema, self.video)

    def record_attempts(self, attempts: int) -> None:
        """Note how many attempts produced this dataset (for the yield in ``mgdata info``); written at the
        next commit or on close."""
        self._info["mgdata"]["attempts"] = int(attempts)

    @property
    def recorded_attempts(self) -> int:
        """The attempt count last noted with :meth:`record_attempts` (0 if never)."""
        return int(self._info["mgdata"].get("attempts") or 0)

    # --- EpisodeSink -------------------------------------------------------------------------------------

    def set_scene(self, mjb: bytes) -> None:
        self._current_stager().set_scene(mjb)

    def add_frame(self, frame: Frame) -> None:
        self._current_stager().add_frame(frame)

    def _current_stager(self) -> EpisodeStager:
        if self._stager is None:
            self._stager = self.stager(work_dir(self.root) / "staging" / "episode")
        return self._stager

    def end_episode(self, meta: EpisodeMeta) -> None:
        if self._stager is None:
            raise DatasetError("end_episode() without any add_frame()")
        stager, self._stager = self._stager, None
        try:
            stager.end_episode(meta)
        except BaseException:
            stager.discard_episode()
            raise
        try:
            self.append_staged(stager.path)
        except BaseException:
            shutil.rmtree(stager.path, ignore_errors=True)
            raise

    def discard_episode(self) -> None:
        if self._stager is not None:
            self._stager.discard_episode()
            self._stager = None

    # --- appending ---------------------------------------------------------------------------------------

    def append_staged(self, path: Path, *, remove: bool = True,
                      extra: Callable[[int], Mapping[str, bytes]] | None = None) -> int:
        """Append a staged episode folder (see :class:`EpisodeStager`); returns its episode index.

        Its videos are copied packet by packet (no re-encode). ``remove`` deletes the folder afterwards.
        ``extra``: more files that belong to the episode (e.g. teleop's raw leader stream), committed in the
        same transaction: called with the new episode's index, it returns {path relative to the root: bytes}
        (new paths only; not listed in ``info.json``'s checksums).
        """
        if self._stale:
            raise DatasetError(f"{self.root}: an earlier commit failed half-way; reopen it to recover")
        staged = StagedEpisode.load(Path(path))
        if staged.schema != self.schema:
            raise DatasetError(f"{path}: staged with schema {staged.schema}, the dataset has {self.schema}")
        if staged.video != self.video:
            raise DatasetError(f"{path}: staged with video settings {staged.video}, the dataset has "
                               f"{self.video}")
        table = staged.frames_table()
        tx = Transaction(self.root)
        try:
            state = self._commit_episode(staged, table, tx)
            for rel, data in (extra(len(self._records)) if extra is not None else {}).items():
                if rel in tx.files or (self.root / rel).exists():
                    raise DatasetError(f"{self.root}: {rel} already exists; an episode's extra files are new")
                tx.path(rel).write_bytes(data)
        except BaseException:
            tx.abort()
            raise
        self._install(tx, state)
        if remove:
            shutil.rmtree(staged.path)
        return self._records[-1].index

    def _commit_episode(self, staged: StagedEpisode, frames: pa.Table, tx: Transaction) -> tuple:
        s, info = self.schema, self._info
        ep, length, start = len(self._records), staged.length, int(info["total_frames"])
        last = self._records[-1] if self._records else None
        tasks = list(self._tasks)
        if staged.task not in tasks:
            tasks.append(staged.task)
        task_index = tasks.index(staged.task)

        # data rows
        index_values = {
            "timestamp": layout.timestamps(length, s.fps).reshape(-1, 1),
            "frame_index": np.arange(length, dtype=np.int64).reshape(-1, 1),
            "episode_index": np.full((length, 1), ep, np.int64),
            "index": np.arange(start, start + length, dtype=np.int64).reshape(-1, 1),
            "task_index": np.full((length, 1), task_index, np.int64),
        }
        values = {c.key: c.from_arrow(frames.column(c.key)) for c in self._frame_cols} | index_values
        rows = pa.Table.from_arrays([c.to_arrow(values[c.key]) for c in layout.all_columns(s)],
                                    schema=layout.data_arrow_schema(s))
        data_ref = last.data if last else layout.FileRef()
        old_data = self.root / layout.data_path(data_ref)
        per_file = info["mgdata"].get("episodes_per_file") or ep + 1  # absent in older datasets: no limit
        if last and (old_data.stat().st_size + (staged.path / "frames.parquet").stat().st_size >
                     info["data_files_size_in_mb"] * _MB or self._episodes_in_data_file() >= per_file):
            data_ref = data_ref.next(info["chunks_size"])
        elif last:
            rows = pa.concat_tables([pq.read_table(old_data, schema=rows.schema), rows])
        layout.write_data_file(rows, tx.path(layout.data_path(data_ref)))

        # videos: copy the staged packets after the current file's
        spans = {}
        for cam in s.cameras:
            key = layout.video_key(cam)
            segment = staged.video_file(key)
            ref, offset = (last.videos[key].ref, round(last.videos[key].to_timestamp * s.fps)) if last else \
                (layout.FileRef(), 0)
            parts = [(segment, 0, length)]
            if offset:
                current = self.root / layout.video_path(key, ref)
                size = current.stat().st_size + segment.stat().st_size
                too_big = size > info["video_files_size_in_mb"] * _MB
                too_long = (offset + length) / s.fps > info["mgdata"]["video_file_seconds"]
                if too_big or too_long:
                    ref, offset = ref.next(info["chunks_size"]), 0
                else:
                    parts.insert(0, (current, 0, offset))
            remux(parts, tx.path(layout.video_path(key, ref)), s.fps)
            spans[key] = VideoSpan(ref, offset / s.fps, (offset + length) / s.fps)

        # the compiled scene, once per base task: rewrites the last scenes file only (or starts the next)
        scene, scenes = None, self._scenes
        if staged.scene_file is not None:
            scene, scenes = scenes.with_scene(staged.meta.task_id, staged.scene_file.read_bytes())
            if scenes is not self._scenes:
                scenes.write(tx.path(scenes.path))

        # per-episode and dataset stats
        ep_stats: dict[str, FeatureStats] = {
            key: image_stats(staged.histograms[key], length) if image else numeric_stats(values[key])
            for key, image in stats_features(s)}
        numeric = _merged(self._numeric, ep_stats, s)
        hist_sum = {k: self._hist_sum[k] + staged.histograms[k] for k in self._hist_sum}
        total = start + length
        ds_stats = {key: image_stats(hist_sum[key], total) if image else numeric[key]
                    for key, image in stats_features(s)}

        # episodes table (rolls over like data files)
        meta_ref, ep_table = (last.meta_file, self._episodes_table) if last else (layout.FileRef(), None)
        if ep_table is not None and (ep_table.nbytes > info["data_files_size_in_mb"] * _MB
                                     or ep_table.num_rows >= per_file):
            meta_ref, ep_table = meta_ref.next(info["chunks_size"]), None
        record = EpisodeRecord(ep, length, staged.task, data_ref, start, spans, meta_ref, staged.meta,
                               ep_stats, dict(staged.histograms), scene)
        row = record_to_table(record, s)
        ep_table = row if ep_table is None else pa.concat_tables([ep_table, row])
        pq.write_table(ep_table, tx.path(layout.episodes_path(meta_ref)))

        if tasks != self._tasks:
            write_tasks(tasks, tx.path(layout.TASKS_PATH))
        tx.path(layout.STATS_PATH).write_text(dump_json(stats_to_json(ds_stats)))
        checksums = dict(info["mgdata"]["sha256"])
        checksums.update({rel: sha256_file(tmp) for rel, tmp in tx.files.items()})
        new_info = dict(info, total_episodes=ep + 1, total_frames=total, total_tasks=len(tasks),
                        splits={"train": f"0:{ep + 1}"})
        new_info["mgdata"] = dict(info["mgdata"], sha256=dict(sorted(checksums.items())))
        if scenes is not self._scenes:  # a dataset written before chunked scenes learns its file size
            new_info["mgdata"]["scenes_per_file"] = scenes.per_file
        tx.path(layout.INFO_PATH).write_text(dump_json(new_info))
        tally = self._tally.plus(staged.meta)
        _write_card(tx, new_info, tasks, tally)  # after the checksums: the card is derived, not recorded
        return record, tasks, numeric, staged.histograms, ep_table, new_info, scenes, tally

    def _episodes_in_data_file(self) -> int:
        """Episodes in the current (last) data file."""
        last, n = self._records[-1].data, 0
        for rec in reversed(self._records):
            if rec.data != last:
                break
            n += 1
        return n

    def _install(self, tx: Transaction, state: tuple) -> None:
        """Commit ``tx`` and take its new state in memory, as one step that Ctrl-C cannot split.

        If the commit itself fails, the disk no longer matches what this writer holds: it refuses further
        appends, ``close`` leaves ``info.json`` alone, and the next :meth:`open` recovers the committed state.
        """
        with sigint_deferred():
            try:
                tx.commit()
            except BaseException:
                self._stale = True
                raise
            self._apply(*state)

    def _apply(self, record: EpisodeRecord, tasks: list[str], numeric: dict[str, FeatureStats],
               hists: dict[str, np.ndarray], ep_table: pa.Table, info: dict, scenes: SceneAppender,
               tally: EpisodeTally) -> None:
        self._records.append(record)
        self._tasks = tasks
        self._numeric = numeric
        for key, h in hists.items():
            self._hist_sum[key] += h
        self._episodes_table = ep_table
        self._info = info
        self._scenes = scenes
        self._tally = tally

    # --- closing -----------------------------------------------------------------------------------------

    def close(self) -> None:
        """Drop an unfinished episode, write pending info (attempts) and bring the card up to date (a
        dataset written before cards gets one), release the dataset."""
        if self._lock is None:
            return
        self.discard_episode()
        new_info = read_info(self.root / layout.INFO_PATH) != self._info
        card = self.root / layout.CARD_PATH
        current = render_card(self._info, self._tasks, self._tally)
        new_card = not card.is_file() or card.read_bytes() != current.encode("utf-8")
        if (new_info or new_card) and not self._stale:
            tx = Transaction(self.root)
            if new_info:
                tx.path(layout.INFO_PATH).write_text(dump_json(self._info))
            if new_card:
                tx.path(layout.CARD_PATH).write_text(current, encoding="utf-8")
            with sigint_deferred():
                tx.commit()
        self._lock.release()
        self._lock = None
        wdir = work_dir(self.root)
        (wdir / "lock").unlink(missing_ok=True)
        shutil.rmtree(wdir / "staging", ignore_errors=True)
        if wdir.exists() and not any(wdir.iterdir()):
            wdir.rmdir()

    def __enter__(self) -> DatasetWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _write_card(tx: Transaction, info: dict, tasks: list[str], tally: EpisodeTally) -> None:
    """The dataset card of ``info``, ``tasks`` and ``tally`` into ``tx`` (:mod:`mgdata.record.card`)."""
    tx.path(layout.CARD_PATH).write_text(render_card(info, tasks, tally), encoding="utf-8")


def _merged(numeric: dict[str, FeatureStats], episode: Mapping[str, FeatureStats],
            schema: DatasetSchema) -> dict[str, FeatureStats]:
    """The numeric dataset stats with one more episode's stats merged in (:func:`merge_stats`)."""
    return {key: merge_stats(numeric.get(key), episode[key]) for key, image in stats_features(schema)
            if not image}
