"""The compiled scenes of a dataset (``meta/scenes/chunk-*/file-*.parquet``): one row per base task,
delta-coded, at most ``mgdata.scenes_per_file`` scenes per file.

A jar task's compiled model (MJB, ``mgdata.record.physics.model_bytes``) is 5.8 MB, mostly the robot's and
the objects' meshes, which every task of a family shares: two jar tasks' MJBs have the same size and differ
in a few % of their bytes. So the first scene of each MJB size is stored whole and every later one as its
byte-wise XOR with that one (mostly zeros); zstd (level 1) compresses the first to ~2.5 MB and each later
one to ~45 KB. The ``data`` column holds each scene's standard zstd frame, written as it is (parquet's own
compression off; schema metadata ``mgdata.data: zstd``), so a writer that rewrites the last file copies the
frames it holds instead of decompressing and compressing every one again. Decoding needs only ``pyarrow``
(``pa.Codec("zstd").decompress(data, decompressed_size=size)``, or any zstd tool) and ``numpy``; files
written before framing (no such metadata) hold the bytes themselves and still read.

Files are chunked like the data files (``layout.SCENES_PATH``: ``file-000``, ``file-001``, …, a new
``chunk-NNN`` every ``chunks_size`` files), each holding at most ``scenes_per_file`` scenes
(``info.json``; ``layout.SCENES_PER_FILE`` by default), one row group per scene (statistics on ``scene``
only), so one scene is read without decoding the others. A new scene goes into the last file (rewritten in
its episode's commit) or starts the next one; earlier files never change, and a delta's base may live in
an earlier file. Storage order: files in order, rows in order. Datasets written before chunking hold every
scene in one file, ``meta/scenes.parquet`` (``layout.LEGACY_SCENES_PATH``), which is read first and never
rewritten: a resumed older dataset adds its new scenes in chunked files beside it (their deltas coded
against a whole scene of the old file, if one has their size).

Columns: ``scene`` (id ``task_<task id:06d>_<sha256[:16]>``, referenced by the episodes-table column
``mgdata/scene``), ``task_id``, ``sha256`` and ``size`` of the MJB, ``base`` (``null``: ``data`` is the MJB;
else the id of the scene ``data`` is XOR-coded against), ``data`` (zstd frame of ``size`` bytes).

Example::

    scenes = Scenes.read(root)                     # every scenes file's rows, data not read yet
    mjb = scenes.mjb("task_000012_9f3a1c0d2b4e7a65")
    model = mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb})
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import FileView

FRAMED = {b"mgdata.data": b"zstd"}
"""Schema metadata of a scenes file whose ``data`` are zstd frames (files without it hold the bytes)."""
SCHEMA = pa.schema([pa.field("scene", pa.string()), pa.field("task_id", pa.int64()),
                    pa.field("sha256", pa.string()), pa.field("size", pa.int64()),
                    pa.field("base", pa.string()), pa.field("data", pa.large_binary())], metadata=FRAMED)
_META = [name for name in SCHEMA.names if name != "data"]
_CHUNKED = re.compile(r"chunk-(\d+)/file-(\d+)\.parquet$")


def scene_id(task_id: int, sha256: str) -> str:
    return f"task_{task_id:06d}_{sha256[:16]}"


def scene_files(files: FileView) -> list[str]:
    """The scenes files of a dataset (paths relative to its root) in storage order: the legacy single file
    if there is one, then the chunked files."""
    legacy = [layout.LEGACY_SCENES_PATH] if files.exists(layout.LEGACY_SCENES_PATH) else []
    return legacy + sorted(files.glob(layout.SCENES_DIR + "/chunk-*/file-*.parquet"), key=_order)


def scenes_file_ref(rel: str) -> layout.FileRef | None:
    """The (chunk, file) of a chunked scenes file's path (``None``: the legacy file or another name)."""
    match = _CHUNKED.search(rel)
    return layout.FileRef(int(match.group(1)), int(match.group(2))) if match else None


def _order(rel: str) -> tuple[int, int, str]:
    ref = scenes_file_ref(rel)
    return (ref.chunk, ref.file, rel) if ref else (-1, -1, rel)


def write_scenes(rows: Iterable[Mapping[str, Any]], path: Path) -> None:
    """Write scenes rows (``data``: the MJB or its XOR delta) to ``path``, one row group per scene."""
    _write_packed(({**row, "data": _Packed.of(row["data"])} for row in rows), path)


def _write_packed(rows: Iterable[Mapping[str, Any]], path: Path) -> None:
    """Write scenes rows whose ``data`` is :class:`_Packed` (its zstd frame is stored as it is)."""
    with pq.ParquetWriter(path, SCHEMA, compression="none", use_dictionary=False,
                          write_statistics=["scene"]) as out:
        for row in rows:
            columns = {f.name: pa.array([row[f.name].data if f.name == "data" else row[f.name]], f.type)
                       for f in SCHEMA}
            out.write_table(pa.table(columns, schema=SCHEMA))


@dataclass(frozen=True)
class SceneRow:
    """One stored scene, without its data.

    Attributes:
        scene: its id; task_id; sha256, size: of its MJB.
        base: ``None`` (stored whole) or the id of the whole scene it is XOR-coded against.
        file: the scenes file holding it (relative to the dataset root); group: its row group there (in
            the legacy file, its row).
    """

    scene: str
    task_id: int
    sha256: str
    size: int
    base: str | None
    file: str
    group: int


class _Packed(NamedTuple):
    """Bytes as one zstd frame (and their length, to decompress them): how scenes are held and stored."""

    data: bytes
    size: int

    @classmethod
    def of(cls, raw: bytes) -> _Packed:
        return cls(_CODEC.compress(raw, asbytes=True), len(raw))

    def raw(self) -> bytes:
        return _CODEC.decompress(self.data, decompressed_size=self.size, asbytes=True)


_CODEC = pa.Codec("zstd", compression_level=1)
"""How scene bytes are packed: a whole jar scene to ~2.5 MB, a delta to ~45 KB."""


class Scenes:
    """A dataset's stored scenes, as read: every row's metadata in storage order; :meth:`mjb` reads one
    scene's row group (and its base's) and decodes it. Read-only (a writer appends with
    :class:`SceneAppender`).

    Attributes:
        files: the scenes files read (relative paths, storage order).
    """

    def __init__(self, view: FileView, rows: list[SceneRow], legacy: Mapping[str, _Packed],
                 framed: Collection[str] = ()) -> None:
        self._view = view
        self._framed = frozenset(framed)  # the files whose data are zstd frames
        self._rows = rows
        self._by_id = {r.scene: r for r in rows}
        self._legacy = legacy  # the legacy file's data (one row group: read whole, held packed)
        self._whole: tuple[str, bytes] | None = None  # the last whole scene decoded (deltas share it)
        self.files = list(dict.fromkeys(r.file for r in rows))

    @classmethod
    def read(cls, root: Path | FileView, skip: Collection[str] = ()) -> Scenes:
        """The scenes of the dataset at ``root`` (empty if it has none), leaving out the files in ``skip``
        (damaged ones). A file with other columns, or a chunked one with several scenes in a row group, or a
        scene stored twice: :class:`DatasetError`."""
        view = root if isinstance(root, FileView) else FileView(Path(root))
        rows: list[SceneRow] = []
        legacy: dict[str, _Packed] = {}
        seen: dict[str, str] = {}
        framed: list[str] = []
        for rel in scene_files(view):
            if rel in skip:
                continue
            path = view.path(rel)
            try:
                with pq.ParquetFile(path) as pf:
                    names = pf.schema_arrow.names
                    if names != SCHEMA.names:
                        raise DatasetError(f"{path}: columns {names}, expected {SCHEMA.names}")
                    meta = pf.read(columns=_META).to_pylist()
                    if (pf.schema_arrow.metadata or {}).get(b"mgdata.data") == FRAMED[b"mgdata.data"]:
                        framed.append(rel)
                    if rel == layout.LEGACY_SCENES_PATH:
                        data = pf.read(columns=["data"]).column("data")
                        legacy.update({m["scene"]: _Packed.of(data[i].as_buffer())
                                       for i, m in enumerate(meta)})
                    elif pf.num_row_groups != len(meta):
                        raise DatasetError(f"{path}: {len(meta)} scenes in {pf.num_row_groups} row groups, "
                                           "expected one row group per scene")
            except (OSError, pa.ArrowException) as err:
                raise DatasetError(f"{path}: unreadable parquet ({err})") from err
            for i, m in enumerate(meta):
                if m["scene"] in seen:
                    raise DatasetError(f"{path}: scene {m['scene']!r} is stored already in "
                                       f"{view.root / seen[m['scene']]}")
                seen[m["scene"]] = rel
                rows.append(SceneRow(**m, file=rel, group=i))
        return cls(view, rows, legacy, framed)

    def __contains__(self, scene: str) -> bool:
        return scene in self._by_id

    @property
    def ids(self) -> list[str]:
        return list(self._by_id)

    @property
    def rows(self) -> list[SceneRow]:
        return list(self._rows)

    def row(self, scene: str) -> SceneRow:
        row = self._by_id.get(scene)
        if row is None:
            raise DatasetError(f"{self._view.root / layout.SCENES_DIR}: no scene {scene!r}")
        return row

    def stored(self, scene: str) -> bytes:
        """The stored bytes of ``scene``: its MJB, or its XOR delta against its base."""
        row = self.row(scene)
        if row.file not in self._framed:
            return self._legacy[scene].raw() if row.file == layout.LEGACY_SCENES_PATH else self._data(row)
        try:
            return self.packed(scene).raw()
        except (OSError, pa.ArrowException) as err:
            raise DatasetError(f"{self._view.path(row.file)}: scene {scene!r} does not decode to its "
                               f"recorded size and SHA-256 ({err})") from err

    def packed(self, scene: str) -> _Packed:
        """:meth:`stored`'s bytes as a zstd frame (read as it is from a framed file)."""
        row = self.row(scene)
        if row.file in self._framed:
            return _Packed(self._data(row), row.size)
        if row.file == layout.LEGACY_SCENES_PATH:
            return self._legacy[scene]
        return _Packed.of(self.stored(scene))

    def _data(self, row: SceneRow) -> bytes:
        """The ``data`` cell of ``row`` in its chunked file."""
        scene = row.scene
        path = self._view.path(row.file)
        try:
            with pq.ParquetFile(path) as pf:
                got = pf.read_row_group(row.group, columns=["scene", "data"])
        except (OSError, pa.ArrowException) as err:
            raise DatasetError(f"{path}: unreadable parquet ({err})") from err
        if got.num_rows != 1 or got.column("scene")[0].as_py() != scene:
            raise DatasetError(f"{path}: row group {row.group} does not hold scene {scene!r} (the file "
                               "changed after it was read)")
        return got.column("data")[0].as_py()

    def mjb(self, scene: str) -> bytes:
        """The MJB bytes of ``scene``, decoded and checked against its SHA-256."""
        row = self.row(scene)
        where = self._view.path(row.file)
        data = np.frombuffer(self.stored(scene), np.uint8)
        if row.base is not None:
            if row.base not in self._by_id or self._by_id[row.base].base is not None:
                raise DatasetError(f"{where}: scene {scene!r} is coded against {row.base!r}, which is not a "
                                   "whole scene of this dataset")
            if self._whole is None or self._whole[0] != row.base:
                self._whole = (row.base, self.mjb(row.base))
            base = np.frombuffer(self._whole[1], np.uint8)
            if base.size != data.size:
                raise DatasetError(f"{where}: scene {scene!r} has {data.size} bytes, its base {row.base!r} "
                                   f"{base.size}")
            data = data ^ base
        mjb = data.tobytes()
        if len(mjb) != row.size or hashlib.sha256(mjb).hexdigest() != row.sha256:
            raise DatasetError(f"{where}: scene {scene!r} does not decode to its recorded size and SHA-256")
        return mjb


@dataclass(frozen=True)
class SceneAppender:
    """What a writer holds to append scenes: the stored ids, the whole scene of each MJB size (packed) and
    the rows of the last chunked file (packed: their frames as stored), never the other scenes; immutable
    (:meth:`with_scene` returns a new one, which the writer keeps once its commit is done).

    Attributes:
        per_file: scenes per file; chunks_size: files per chunk.
        ids: every stored scene; bases: MJB size → (id, packed MJB) of the whole scene deltas are coded
            against; current: the last chunked file (``None`` before the first); rows: its rows.

    Example::

        appender = SceneAppender.load(Scenes.read(root), per_file=20, chunks_size=1000)
        sid, appender = appender.with_scene(task_id, mjb)
        appender.write(tx.path(appender.path))     # if it is a new scene
    """

    per_file: int
    chunks_size: int
    ids: frozenset[str] = frozenset()
    bases: Mapping[int, tuple[str, _Packed]] = field(default_factory=dict)
    current: layout.FileRef | None = None
    rows: tuple[dict, ...] = ()

    def __post_init__(self) -> None:
        if self.per_file < 1:
            raise DatasetError(f"scenes_per_file must be >= 1, got {self.per_file}")

    @classmethod
    def load(cls, scenes: Scenes, per_file: int, chunks_size: int) -> SceneAppender:
        """Ready to append to the dataset ``scenes`` was read from."""
        bases: dict[int, tuple[str, _Packed]] = {}
        for row in scenes.rows:
            if row.base is None and row.size not in bases:
                bases[row.size] = (row.scene, _Packed.of(scenes.mjb(row.scene)))
        chunked = [f for f in scenes.files if scenes_file_ref(f) is not None]
        if not chunked:
            return cls(per_file, chunks_size, frozenset(scenes.ids), bases)
        whole = {sid: packed for sid, packed in bases.values()}
        rows = tuple({**{k: getattr(r, k) for k in _META},
                      "data": whole.get(r.scene) or scenes.packed(r.scene)}
                     for r in scenes.rows if r.file == chunked[-1])
        return cls(per_file, chunks_size, frozenset(scenes.ids), bases, scenes_file_ref(chunked[-1]), rows)

    def with_scene(self, task_id: int, mjb: bytes) -> tuple[str, SceneAppender]:
        """The id of ``mjb`` and an appender holding it (``self`` if it is stored already)."""
        digest = hashlib.sha256(mjb).hexdigest()
        sid = scene_id(task_id, digest)
        if sid in self.ids:
            return sid, self
        base = self.bases.get(len(mjb))
        if base is None:
            packed = _Packed.of(mjb)
            bases = {**self.bases, len(mjb): (sid, packed)}
        else:
            delta = np.frombuffer(mjb, np.uint8) ^ np.frombuffer(base[1].raw(), np.uint8)
            packed = _Packed.of(delta.tobytes())
            bases = dict(self.bases)
        row = {"scene": sid, "task_id": task_id, "sha256": digest, "size": len(mjb),
               "base": None if base is None else base[0], "data": packed}
        if self.current is None:
            current, rows = layout.FileRef(), (row,)
        elif len(self.rows) >= self.per_file:
            current, rows = self.current.next(self.chunks_size), (row,)
        else:
            current, rows = self.current, (*self.rows, row)
        return sid, replace(self, ids=self.ids | {sid}, bases=bases, current=current, rows=rows)

    @property
    def path(self) -> str:
        """The last chunked file (relative to the dataset root): what :meth:`write` writes."""
        if self.current is None:
            raise DatasetError("internal: no scenes file yet (append a scene first)")
        return layout.scenes_path(self.current)

    def write(self, path: Path) -> None:
        """Write the last file's rows to ``path`` (their zstd frames as they are)."""
        _write_packed(self.rows, path)
