"""Helpers of the dataset tests: small synthetic datasets written with the real writer."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.record.commit import sha256_file
from mgdata.record.metafiles import dump_json
from mgdata.record.synthetic import SYNTHETIC_SPEC, SyntheticEpisode, synthetic_episode, synthetic_schema
from mgdata.record.writer import DatasetWriter
from tests.helpers import rawdata

SMALL = synthetic_schema(cameras=("front", "wrist", "left"), size=64)
LENGTHS = (23, 31, 17, 40)
GENERATED = {"hold_steps": 10, "kept_only": True}
"""What ``mgdata generate`` promises about its output dataset (``DatasetWriter.create`` arguments)."""


def small_episodes(lengths: tuple[int, ...] = LENGTHS, schema=SMALL) -> list[SyntheticEpisode]:
    return [synthetic_episode(schema, n, seed=10 + i, draw_index=i) for i, n in enumerate(lengths)]


def write_episodes(writer: DatasetWriter, episodes: list[SyntheticEpisode]) -> None:
    for ep in episodes:
        for frame in ep.frames():
            writer.add_frame(frame)
        writer.end_episode(ep.meta)


def write_dataset(root: Path, episodes: list[SyntheticEpisode], **kwargs) -> Path:
    schema = episodes[0].schema
    with DatasetWriter.create(root, schema, spec=SYNTHETIC_SPEC, **kwargs) as writer:
        write_episodes(writer, episodes)
    return root


def to_legacy_scenes(root: Path) -> None:
    """Give a dataset the scenes layout of mgdata before chunked scenes: every row in one
    ``meta/scenes.parquet`` written as that code wrote it (one table, one row group, zstd, no dictionary),
    no ``mgdata.scenes_per_file``, the checksums to match."""
    files = sorted(root.glob("meta/scenes/chunk-*/file-*.parquet"))
    table = pa.concat_tables([_unframed(pq.read_table(p)) for p in files]).combine_chunks()
    legacy = root / "meta/scenes.parquet"
    pq.write_table(table, legacy, compression="zstd", use_dictionary=False)
    shutil.rmtree(root / "meta/scenes")
    info = json.loads((root / "meta/info.json").read_text())
    mg = info["mgdata"]
    sums = {k: v for k, v in mg["sha256"].items() if not k.startswith("meta/scenes/")}
    mg["sha256"] = dict(sorted({**sums, "meta/scenes.parquet": sha256_file(legacy)}.items()))
    del mg["scenes_per_file"]
    (root / "meta/info.json").write_text(dump_json(info))


def _unframed(table: pa.Table) -> pa.Table:
    """A scenes table as mgdata wrote it before zstd frames: ``data`` the bytes, no schema metadata."""
    rows = [{**row, "data": rawdata.unframed(table.schema, row)} for row in table.to_pylist()]
    return pa.Table.from_pylist(rows, schema=table.schema.remove_metadata())


def to_unframed_scenes(root: Path) -> None:
    """Give a dataset's chunked scenes files the layout of mgdata before zstd frames (one row group per
    scene, parquet's zstd, ``data`` the bytes), the checksums to match."""
    info = json.loads((root / "meta/info.json").read_text())
    for path in sorted(root.glob("meta/scenes/chunk-*/file-*.parquet")):
        table = _unframed(pq.read_table(path))
        with pq.ParquetWriter(path, table.schema, compression="zstd", use_dictionary=False,
                              write_statistics=["scene"]) as out:
            for k in range(table.num_rows):
                out.write_table(table.slice(k, 1))
        info["mgdata"]["sha256"][str(path.relative_to(root))] = sha256_file(path)
    (root / "meta/info.json").write_text(dump_json(info))


def tree_digest(root: Path) -> dict[str, str]:
    """Relative path → SHA-256 of every file under ``root``."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def dataset_files(root: Path) -> dict[str, bytes]:
    """Relative path → bytes of every file of a dataset, its ``.mgdata`` run state left out."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".mgdata" not in p.parts}


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)
