"""``mgdata validate --repair DATASET --out NEW``: the intact episodes of a damaged dataset, copied into a new
one.

An episode is intact when every file it lives in matches its recorded checksum
(:mod:`mgdata.record.integrity`): its data file, its video file of each camera, its episodes-table file
and the scenes files holding its scene (and the whole scene that one is coded against).
The intact episodes are re-staged (:mod:`mgdata.record.restage`: video packets copied, no re-encode) and
appended in their order to ``NEW`` with the source's settings, spec, gate and generator identity, so
``mgdata generate`` with the source's options resumes ``NEW``: it continues after the last draw of each task
still in it (a dropped episode that was its task's last draw is generated again, to the same bytes). The
dataset-wide files (``meta/tasks.parquet``, and in a dataset written before chunked scenes
``meta/scenes.parquet``) hold every episode's task text and scene; when one of them is damaged nothing can
be copied and the repair says so. ``NEW`` is built in ``NEW.partial`` and renamed when complete; the source
is never changed.

Example::

    summary = repair_dataset(Path("datasets/jar"), Path("datasets/jar_repaired"))
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from mgdata.errors import DatasetError, OutputError
from mgdata.lock import output_lock
from mgdata.record import layout
from mgdata.record.episodes import EpisodeRecord, records_from_table
from mgdata.record.integrity import damaged_files
from mgdata.record.reader import DatasetReader, read_parquet
from mgdata.record.restage import restage
from mgdata.record.scenes import Scenes
from mgdata.record.writer import DatasetWriter

WHOLE_DATASET = (layout.TASKS_PATH, layout.LEGACY_SCENES_PATH)
"""Files every episode needs: damage there leaves nothing to copy (a damaged chunked scenes file drops the
episodes whose scene, or its base, it holds)."""


@dataclass(frozen=True)
class RepairSummary:
    """What a repair kept and dropped (episode indices of the source), and the damaged files."""

    out: Path
    kept: tuple[int, ...]
    dropped: tuple[int, ...]
    damaged: tuple[str, ...]


class _IntactReader(DatasetReader):
    """A reader of the source that skips damaged episodes-table and scenes files (their episodes are
    dropped) instead of refusing the dataset; positions in :meth:`records` are no longer episode indices."""

    def __init__(self, root: Path, damaged: set[str]) -> None:
        try:
            super().__init__(root)
        except DatasetError:  # a damaged episodes file: read the intact ones only
            if not hasattr(self, "tasks"):  # info.json or tasks unreadable: nothing to go on
                raise
        self._records = []
        for rel in self.files.glob(layout.EPISODES_DIR + "/chunk-*/file-*.parquet"):
            if rel not in damaged:
                path = self.files.path(rel)
                self._records += records_from_table(read_parquet(path), self.schema, str(path))
        self._data_cache = None
        self._scenes = Scenes.read(self.files, skip=damaged)


def _files_of(rec: EpisodeRecord) -> set[str]:
    """The dataset files episode ``rec`` lives in."""
    files = {layout.data_path(rec.data), layout.episodes_path(rec.meta_file)}
    return files | {layout.video_path(k, span.ref) for k, span in rec.videos.items()}


def _scene_intact(scenes: Scenes, scene: str | None) -> bool:
    """``scene`` (``None``: the episode has none) and its base are in the intact scenes files."""
    if scene is None:
        return True
    if scene not in scenes:
        return False
    base = scenes.row(scene).base
    return base is None or base in scenes


def repair_dataset(source: Path, out: Path) -> RepairSummary:
    """Write ``out`` from the intact episodes of ``source`` (module docstring)."""
    source, out = Path(source), Path(out)
    with output_lock(out):
        if out.exists():
            raise OutputError(f"--out {out}: already exists; choose a new folder")
        damaged = {d.rel for d in damaged_files(source)}
        fatal = sorted(damaged & set(WHOLE_DATASET))
        if fatal:
            raise DatasetError(f"{source / fatal[0]}: damaged, and every episode needs it: nothing can be "
                               "copied; generate the dataset again into a new --out")
        reader = _IntactReader(source, damaged)
        total = int(reader.info["total_episodes"])
        scenes = reader.scenes()
        keep = [k for k, rec in enumerate(reader.records())
                if not _files_of(rec) & damaged and _scene_intact(scenes, rec.scene)]
        kept = tuple(reader.records()[k].index for k in keep)
        part = out.with_name(out.name + ".partial")
        shutil.rmtree(part, ignore_errors=True)
        mg = reader.info["mgdata"]
        with DatasetWriter.create_like(part, reader) as writer:
            stage = writer.root / layout.WORK_DIR / "repair"
            for k in keep:
                writer.append_staged(restage(reader, k, stage))
            if mg.get("attempts") is not None:
                writer.record_attempts(int(mg["attempts"]))
        os.replace(part, out)
    dropped = tuple(sorted(set(range(total)) - set(kept)))
    return RepairSummary(out, kept, dropped, tuple(sorted(damaged)))
