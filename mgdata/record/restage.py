"""One committed episode as a staged-episode folder again (:mod:`mgdata.record.staging`), ready for
:meth:`mgdata.record.writer.DatasetWriter.append_staged`: ``mgdata merge`` joins shards with it and
``mgdata validate --repair`` copies the intact episodes of a damaged dataset. Video packets are copied
(no re-encode), so the episode's bytes in the new dataset are those of the old one.

Example::

    writer.append_staged(restage(DatasetReader(Path("ds/s0")), 0, stage_dir))
"""

from __future__ import annotations

import json
import shutil
from dataclasses import asdict
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.record import layout
from mgdata.record.metadata import meta_to_dict
from mgdata.record.reader import DatasetReader
from mgdata.record.staging import EPISODE_JSON, FRAMES_PARQUET, SCENE_MJB, STAGED_FORMAT
from mgdata.record.video import remux


def restage(reader: DatasetReader, e: int, path: Path) -> Path:
    """Episode ``e`` of ``reader`` as a staged-episode folder (:mod:`mgdata.record.staging`) at ``path``:
    its frame columns, each camera's packets (copied), its scene, metadata and pixel histograms."""
    rec, s = reader.record(e), reader.schema
    shutil.rmtree(path, ignore_errors=True)
    path.mkdir(parents=True)
    table = reader.data_table(rec.data)
    lo = rec.from_index - int(table.column("index")[0].as_py())
    rows = table.slice(lo, rec.length)
    frame_cols = [c.key for c in layout.frame_columns(s)]
    pq.write_table(pa.Table.from_arrays([rows.column(k) for k in frame_cols], names=frame_cols),
                   path / FRAMES_PARQUET)
    for cam in s.cameras:
        src, start = reader.video_file(e, cam)
        remux([(src, start, rec.length)], path / f"{layout.video_key(cam)}.mp4", s.fps)
    if s.physics_state_size:
        (path / SCENE_MJB).write_bytes(reader.scene_mjb(e))
    doc = {"format": STAGED_FORMAT, "length": rec.length, "task": rec.task, "meta": meta_to_dict(rec.meta),
           "histograms": {k: h.tolist() for k, h in rec.histograms.items()},
           "schema": asdict(s), "video": asdict(reader.video)}
    (path / EPISODE_JSON).write_text(json.dumps(doc))
    return path
