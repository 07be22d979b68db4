"""Plant inconsistencies in a dataset as a careful forger would: change a column or a metadata field, then
bring everything derived from it up to date (per-episode and dataset stats, the SHA-256 sums in
``info.json``, the dataset card), so that only the safety audit can notice."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.record import layout
from mgdata.record.card import write_card
from mgdata.record.commit import sha256_file
from mgdata.record.metadata import meta_to_columns
from mgdata.record.reader import DatasetReader
from mgdata.record.stats import merge_stats, numeric_stats, stats_from_json, stats_to_json


def _rehash(root: Path, *rels: str) -> None:
    info_path = root / layout.INFO_PATH
    info = json.loads(info_path.read_text())
    for rel in rels:
        info["mgdata"]["sha256"][rel] = sha256_file(root / rel)
    info_path.write_text(json.dumps(info, indent=4))
    write_card(root)


def _edit_episode_row(root: Path, episode: int, change: Callable[[dict[str, Any]], None]) -> str:
    rec = DatasetReader(root).record(episode)
    rel = layout.episodes_path(rec.meta_file)
    table = pq.read_table(root / rel)
    rows = table.to_pylist()
    change(next(r for r in rows if r["episode_index"] == episode))
    pq.write_table(pa.Table.from_pylist(rows, schema=table.schema), root / rel)
    return rel


def edit_column(root: Path, key: str, episode: int, change: Callable[[np.ndarray], None]) -> None:
    """Apply ``change`` in place to episode ``episode``'s (T, width) values of feature ``key``, then update
    the episode's stats, ``meta/stats.json`` and the checksums."""
    reader = DatasetReader(root)
    rec = reader.record(episode)
    col = next(c for c in layout.all_columns(reader.schema) if c.key == key)
    rel = layout.data_path(rec.data)
    table = pq.read_table(root / rel)
    values = col.from_arrow(table.column(key)).copy()
    lo = int(np.searchsorted(table.column("index").to_numpy(), rec.from_index))
    part = values[lo:lo + rec.length]
    change(part)
    pq.write_table(table.set_column(table.column_names.index(key), key, col.to_arrow(values)), root / rel)

    ep_stats = numeric_stats(part)

    def set_stats(row: dict[str, Any]) -> None:
        for stat, value in ep_stats.items():
            row[f"stats/{key}/{stat}"] = value.tolist()

    meta_rel = _edit_episode_row(root, episode, set_stats)
    reader = DatasetReader(root)
    merged = None
    for r in reader.records():  # the dataset stats are the episodes' merged in order
        merged = merge_stats(merged, r.stats[key])
    stats = stats_from_json(json.loads((root / layout.STATS_PATH).read_text()))
    stats[key] = merged
    (root / layout.STATS_PATH).write_text(json.dumps(stats_to_json(stats), indent=4))
    _rehash(root, rel, meta_rel, layout.STATS_PATH)


def edit_meta(root: Path, episode: int, **changes: Any) -> None:
    """Change fields of episode ``episode``'s :class:`EpisodeMeta` in the episodes table (and checksum)."""
    meta = DatasetReader(root).record(episode).meta
    columns = meta_to_columns(replace(meta, **changes))
    _rehash(root, _edit_episode_row(root, episode, lambda row: row.update(columns)))
