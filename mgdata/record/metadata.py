"""EpisodeMeta ↔ plain data: JSON for staged episodes, ``mgdata/<field>`` columns for the episodes table.

Flat fields become typed columns (``mgdata/seed`` int64, ``mgdata/t_engage`` nullable int64 …); nested
ones (``formulas``, ``t_violation``, ``variation``) are JSON text, so the table is readable with any parquet
tool and without decoding video.
"""

from __future__ import annotations

import json
import math
from dataclasses import fields
from typing import Any

import pyarrow as pa

from mgdata.errors import DatasetError
from mgdata.record.episode import EpisodeMeta

PREFIX = "mgdata/"
_NESTED = ("formulas", "t_violation", "variation")
_TYPES: dict[str, pa.DataType] = {
    "family": pa.string(), "task_id": pa.int64(), "condition": pa.string(), "prompt": pa.string(),
    "spec_name": pa.string(), "formulas": pa.string(), "seed": pa.int64(), "draw_index": pa.int64(),
    "success": pa.bool_(), "verdict": pa.bool_(), "kept": pa.bool_(), "t_engage": pa.int64(),
    "t_violation": pa.string(), "failure_stage": pa.string(), "failure_reason": pa.string(),
    "grasp_id": pa.string(), "variation": pa.string(), "source": pa.string(), "software_version": pa.string(),
    "max_penetration": pa.float64(), "penetration_step": pa.int64(), "penetration_bodies": pa.string(),
}
OPTIONAL = ("max_penetration", "penetration_step", "penetration_bodies")
"""Fields a dataset written before them lacks (read as ``None``)."""
_INT64 = (-(2**63), 2**63 - 1)


def meta_fields() -> tuple[pa.Field, ...]:
    """The ``mgdata/...`` columns of the episodes table, in EpisodeMeta field order."""
    return tuple(pa.field(PREFIX + f.name, _TYPES[f.name]) for f in fields(EpisodeMeta))


def meta_to_dict(meta: EpisodeMeta) -> dict[str, Any]:
    """JSON-able plain data (nested mappings as dicts, in their given order)."""
    out: dict[str, Any] = {}
    for f in fields(EpisodeMeta):
        value = getattr(meta, f.name)
        out[f.name] = dict(value) if f.name in _NESTED else value
    return out


def meta_from_dict(data: dict[str, Any], where: str) -> EpisodeMeta:
    """Inverse of :func:`meta_to_dict`; ``where`` names the file for errors."""
    names = [f.name for f in fields(EpisodeMeta)]
    data = {**dict.fromkeys(OPTIONAL), **data}
    missing = [n for n in names if n not in data]
    if missing:
        raise DatasetError(f"{where}: episode metadata lacks {', '.join(missing)}")
    try:
        return EpisodeMeta(**{n: data[n] for n in names})
    except TypeError as err:
        raise DatasetError(f"{where}: bad episode metadata ({err})") from err


def check_meta(meta: EpisodeMeta, constraints: tuple[str, ...]) -> None:
    """Refuse metadata the dataset cannot store faithfully (wrong constraint ids, out-of-range ints)."""
    if set(meta.formulas) != set(constraints):
        raise DatasetError(f"EpisodeMeta.formulas has constraints {sorted(meta.formulas)}; the dataset "
                           f"schema has {list(constraints)}")
    unknown = set(meta.t_violation) - set(constraints)
    if unknown:
        raise DatasetError(f"EpisodeMeta.t_violation names unknown constraints {sorted(unknown)}")
    for name in ("task_id", "seed", "draw_index", "t_engage", "penetration_step"):
        value = getattr(meta, name)
        if value is not None and not (isinstance(value, int) and _INT64[0] <= value <= _INT64[1]):
            raise DatasetError(f"EpisodeMeta.{name}={value!r} must be an int64")
    depth = meta.max_penetration
    if depth is not None and not (isinstance(depth, float) and math.isfinite(depth) and depth >= 0.0):
        raise DatasetError(f"EpisodeMeta.max_penetration={depth!r} must be a finite float >= 0")
    try:
        json.dumps(dict(meta.variation), allow_nan=False)
    except (TypeError, ValueError) as err:
        raise DatasetError(f"EpisodeMeta.variation is not plain JSON data ({err})") from err


def meta_to_columns(meta: EpisodeMeta) -> dict[str, Any]:
    """``{"mgdata/<field>": value}`` with nested fields as JSON text."""
    out: dict[str, Any] = {}
    for name, value in meta_to_dict(meta).items():
        if name in _NESTED:
            value = json.dumps(value, sort_keys=name == "variation", allow_nan=False)
        out[PREFIX + name] = value
    return out


def meta_from_columns(row: dict[str, Any], where: str) -> EpisodeMeta:
    """Inverse of :func:`meta_to_columns` for one row of the episodes table."""
    data: dict[str, Any] = {}
    for f in fields(EpisodeMeta):
        key = PREFIX + f.name
        if key not in row and f.name in OPTIONAL:
            continue
        if key not in row:
            raise DatasetError(f"{where}: episodes table lacks column {key!r}")
        value = row[key]
        if f.name in _NESTED:
            try:
                value = json.loads(value)
            except (TypeError, ValueError) as err:
                raise DatasetError(f"{where}: column {key!r} is not JSON ({err})") from err
        data[f.name] = value
    return meta_from_dict(data, where)
