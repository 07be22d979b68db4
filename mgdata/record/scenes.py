"""The compiled scenes of a dataset (``meta/scenes.parquet``): one row per base task, delta-coded.

A jar task's compiled model (MJB, ``mgdata.record.physics.model_bytes``) is 4.2 MB, mostly the robot's and
the objects' meshes, which every task of a family shares: two jar tasks' MJBs have the same size and differ
in ~2.5 % of their bytes. So the first scene of each MJB size is stored whole and every later one as its
byte-wise XOR with that one (mostly zeros); parquet's zstd compresses the first to ~1.75 MB and each later
one to ~45 KB. Decoding needs only ``pyarrow`` and ``numpy``.

Columns: ``scene`` (id ``task_<task id:06d>_<sha256[:16]>``, referenced by the episodes-table column
``mgdata/scene``), ``task_id``, ``sha256`` and ``size`` of the MJB, ``base`` (``null``: ``data`` is the MJB;
else the id of the scene ``data`` is XOR-coded against), ``data``.

Example::

    scenes = Scenes.read(root / "meta/scenes.parquet")
    mjb = scenes.mjb("task_000012_9f3a1c0d2b4e7a65")
    model = mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb})
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.errors import DatasetError

SCHEMA = pa.schema([pa.field("scene", pa.string()), pa.field("task_id", pa.int64()),
                    pa.field("sha256", pa.string()), pa.field("size", pa.int64()),
                    pa.field("base", pa.string()), pa.field("data", pa.large_binary())])


def scene_id(task_id: int, sha256: str) -> str:
    return f"task_{task_id:06d}_{sha256[:16]}"


_CODEC = pa.Codec("zstd", compression_level=1)
"""How a scene's ``data`` is held in memory between commits (the table is rewritten whole at each new scene,
so a writer holds every scene of its dataset: raw, 26 clutter_liquid scenes took 183 MB; packed, ~41 MB)."""


class Scenes:
    """The scenes table in memory (rows in storage order, ``data`` zstd-packed); immutable:
    :meth:`with_scene` returns a new one."""

    def __init__(self, rows: list[dict], where: str = "meta/scenes.parquet") -> None:
        self._rows = [_pack(r) for r in rows]
        self.where = where
        self._by_id = {r["scene"]: r for r in self._rows}

    @classmethod
    def _packed(cls, rows: list[dict], where: str) -> Scenes:
        scenes = cls([], where)
        scenes._rows = rows
        scenes._by_id = {r["scene"]: r for r in rows}
        return scenes

    @classmethod
    def read(cls, path: Path) -> Scenes:
        """The table at ``path`` (empty if the file does not exist)."""
        if not path.exists():
            return cls([], str(path))
        try:
            table = pq.read_table(path)
        except (OSError, pa.ArrowException) as err:
            raise DatasetError(f"{path}: unreadable parquet ({err})") from err
        if table.schema.names != SCHEMA.names:
            raise DatasetError(f"{path}: columns {table.schema.names}, expected {SCHEMA.names}")
        meta = table.drop_columns(["data"]).to_pylist()
        data = table.column("data")
        return cls._packed([_pack({**m, "data": data[i].as_buffer()}) for i, m in enumerate(meta)], str(path))

    def __contains__(self, scene: str) -> bool:
        return scene in self._by_id

    @property
    def ids(self) -> list[str]:
        return list(self._by_id)

    def mjb(self, scene: str) -> bytes:
        """The MJB bytes of ``scene``, decoded and checked against its SHA-256."""
        row = self._by_id.get(scene)
        if row is None:
            raise DatasetError(f"{self.where}: no scene {scene!r}")
        data = np.frombuffer(_unpack(row), np.uint8)
        if row["base"] is not None:
            if row["base"] not in self._by_id or self._by_id[row["base"]]["base"] is not None:
                raise DatasetError(f"{self.where}: scene {scene!r} is coded against {row['base']!r}, which "
                                   "is not a whole scene of this table")
            base = np.frombuffer(self.mjb(row["base"]), np.uint8)
            if base.size != data.size:
                raise DatasetError(f"{self.where}: scene {scene!r} has {data.size} bytes, its base "
                                   f"{row['base']!r} {base.size}")
            data = data ^ base
        mjb = data.tobytes()
        if len(mjb) != row["size"] or hashlib.sha256(mjb).hexdigest() != row["sha256"]:
            raise DatasetError(f"{self.where}: scene {scene!r} does not decode to its recorded size and "
                               "SHA-256")
        return mjb

    def with_scene(self, task_id: int, mjb: bytes) -> tuple[str, Scenes]:
        """The id of ``mjb`` and a table holding it (``self`` if it is stored already)."""
        digest = hashlib.sha256(mjb).hexdigest()
        sid = scene_id(task_id, digest)
        if sid in self:
            return sid, self
        base = next((r["scene"] for r in self._rows if r["base"] is None and r["size"] == len(mjb)), None)
        data = mjb if base is None else \
            (np.frombuffer(mjb, np.uint8) ^ np.frombuffer(self.mjb(base), np.uint8)).tobytes()
        row = {"scene": sid, "task_id": task_id, "sha256": digest, "size": len(mjb), "base": base,
               "data": data}
        return sid, Scenes._packed([*self._rows, _pack(row)], self.where)

    def write(self, path: Path) -> None:
        columns = {f.name: pa.array([r[f.name] for r in self._rows], f.type) for f in SCHEMA
                   if f.name != "data"}
        columns["data"] = pa.array((_unpack(r) for r in self._rows), SCHEMA.field("data").type,
                                   size=len(self._rows))
        pq.write_table(pa.table(columns, schema=SCHEMA), path, compression="zstd", use_dictionary=False)


def _pack(row: dict) -> dict:
    """``row`` with its ``data`` compressed (and its length kept, to decompress it)."""
    data = row["data"]
    return {**row, "data": _CODEC.compress(data, asbytes=True), "data_size": len(data)}


def _unpack(row: dict) -> bytes:
    return _CODEC.decompress(row["data"], decompressed_size=row["data_size"], asbytes=True)
