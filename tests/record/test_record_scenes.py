"""Scenes that scale (issue 42, item 3): the compiled scenes are chunked like the data files, a new scene
rewrites only the last scenes file, the writer holds only what it appends against, and datasets written
before chunking (one ``meta/scenes.parquet``) still read, validate, export, copy and resume.

Real jar scenes (5.8 MB MJBs, one per task) go through the real writer with short synthetic episodes."""

from __future__ import annotations

import functools
import hashlib
import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import sha256_file
from mgdata.record.export import export_dataset
from mgdata.record.physics import model_bytes, physics_state
from mgdata.record.reader import DatasetReader
from mgdata.record.repair import repair_dataset
from mgdata.record.rerender import RenderJob, rerender
from mgdata.record.scenes import SceneAppender, Scenes
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from mgdata.sim.scene import build_scene
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe
from tests.helpers import rawdata
from tests.helpers.record import to_legacy_scenes, to_unframed_scenes

WIDTH = 78  # the jar scene's sim.physics_state width
PLAIN = synthetic_schema(cameras=("front",), size=32)
SCHEMA = replace(PLAIN, physics_state_size=WIDTH)
TASKS = (0, 1, 2, 1, 3, 4)
"""The episodes' jar tasks: five scenes (task 1's is stored once), two per file, two files per chunk."""
FILES = ["meta/scenes/chunk-000/file-000.parquet", "meta/scenes/chunk-000/file-001.parquet",
         "meta/scenes/chunk-001/file-000.parquet"]


@functools.cache
def _scene(task: int) -> tuple[bytes, np.ndarray]:
    scene = build_scene(draw_task(load_recipe("jar"), task))
    scene.reset()
    return model_bytes(scene.model), physics_state(scene.model, scene.data)


def mjb(task: int) -> bytes:
    """Jar task ``task``'s compiled scene."""
    return _scene(task)[0]


def append(writer: DatasetWriter, k: int, task: int) -> None:
    """Episode ``k``: a short synthetic episode that ran in jar task ``task``'s scene (every frame at its
    initial state)."""
    ep = synthetic_episode(PLAIN, 6, seed=k, draw_index=k)
    writer.set_scene(mjb(task))
    for frame in ep.frames():
        writer.add_frame(replace(frame, physics_state=_scene(task)[1]))
    writer.end_episode(replace(ep.meta, task_id=task))


def write(root: Path, tasks: tuple[int, ...] = TASKS, **create: object) -> Path:
    with DatasetWriter.create(root, SCHEMA, spec=SYNTHETIC_SPEC, **create) as writer:
        for k, task in enumerate(tasks):
            append(writer, k, task)
    return root


@pytest.fixture(scope="module")
def chunked(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """:data:`TASKS` with two scenes per file and two files per chunk (read-only: copy it to change it)."""
    return write(tmp_path_factory.mktemp("scenes") / "ds", scenes_per_file=2, chunks_size=2)


def snapshot(root: Path) -> dict[str, tuple[int, bytes]]:
    """Every scenes file's (mtime in ns, bytes)."""
    return {str(p.relative_to(root)): (p.stat().st_mtime_ns, p.read_bytes())
            for p in sorted(root.glob("meta/scenes/*/*.parquet"))}


def test_scenes_span_files_and_each_decodes_to_its_sha256(chunked: Path) -> None:
    reader = DatasetReader(chunked)
    assert sorted(str(p.relative_to(chunked)) for p in chunked.glob("meta/scenes/*/*.parquet")) == FILES
    tables = {f: pq.read_table(chunked / f) for f in FILES}
    rows = {f: [{**r, "frame": r["data"], "data": rawdata.unframed(t.schema, r)} for r in t.to_pylist()]
            for f, t in tables.items()}
    assert [len(r) for r in rows.values()] == [2, 2, 1]
    assert all(t.schema.metadata == {b"mgdata.data": b"zstd"} for t in tables.values())
    for f in FILES:  # each cell one zstd frame (magic 28 b5 2f fd), stored without parquet's compression
        assert all(r["frame"][:4] == b"\x28\xb5\x2f\xfd" and len(r["frame"]) < len(r["data"])
                   for r in rows[f])
        meta = pq.ParquetFile(chunked / f).metadata
        data = meta.schema.names.index("data")
        assert {meta.row_group(g).column(data).compression for g in range(meta.num_row_groups)} == \
            {"UNCOMPRESSED"}
    assert [pq.ParquetFile(chunked / f).num_row_groups for f in FILES] == [2, 2, 1]  # one scene per group
    first = rows[FILES[0]][0]
    assert first["base"] is None and first["size"] == len(mjb(0))
    later = [r for f in FILES for r in rows[f]][1:]
    assert all(r["base"] == first["scene"] for r in later)  # bases in an earlier file
    assert all(len(r["data"]) == r["size"] for r in later)
    assert (chunked / FILES[1]).stat().st_size < 200_000  # two XOR deltas, no whole scene
    for e, task in enumerate(TASKS):
        scene = reader.record(e).scene
        assert reader.scene_mjb(e) == mjb(task)
        assert hashlib.sha256(reader.scene_mjb(e)).hexdigest() == reader.scenes().row(scene).sha256
        assert rawdata.scene_model(chunked, scene).nbody == build_scene(draw_task(load_recipe("jar"),
                                                                                 task)).model.nbody
    sums = reader.info["mgdata"]["sha256"]
    assert all(sums[f] == sha256_file(chunked / f) for f in FILES)
    assert reader.info["mgdata"]["scenes_per_file"] == 2
    assert not (chunked / layout.LEGACY_SCENES_PATH).exists()
    report = validate_dataset(chunked)
    assert report.ok, report.problems


def test_a_new_scene_rewrites_only_the_last_scenes_file(chunked: Path, tmp_path: Path) -> None:
    root = shutil.copytree(chunked, tmp_path / "ds")
    with DatasetWriter.open(root) as writer:  # resumed: the appender is rebuilt from the files
        before = snapshot(root)
        append(writer, 6, 0)  # a stored scene: no scenes file written
        assert snapshot(root) == before
        append(writer, 7, 5)  # fills the last file
        after = snapshot(root)
        assert {f: after[f] for f in FILES[:2]} == {f: before[f] for f in FILES[:2]}
        assert after[FILES[2]][1] != before[FILES[2]][1]
        append(writer, 8, 6)  # starts the next one
        new = snapshot(root)
        assert list(new) == [*FILES, "meta/scenes/chunk-001/file-001.parquet"]
        assert {f: new[f] for f in FILES} == {f: after[f] for f in FILES}
    assert [len(pq.read_table(root / f)) for f in new] == [2, 2, 2, 1]
    reader = DatasetReader(root)
    assert [reader.scene_mjb(e) for e in (6, 7, 8)] == [mjb(0), mjb(5), mjb(6)]
    assert validate_dataset(root).ok, validate_dataset(root).problems


def test_scenes_files_written_before_zstd_frames_read_validate_and_resume(chunked: Path,
                                                                         tmp_path: Path) -> None:
    root = shutil.copytree(chunked, tmp_path / "ds")
    to_unframed_scenes(root)
    assert all(pq.read_schema(root / f).metadata is None for f in FILES)
    reader = DatasetReader(root)
    assert [reader.scene_mjb(e) for e in range(len(TASKS))] == [mjb(t) for t in TASKS]
    assert validate_dataset(root).ok, validate_dataset(root).problems
    old = snapshot(root)
    with DatasetWriter.open(root) as writer:
        append(writer, 6, 5)  # the last (unframed) file is rewritten framed; the others stay as they are
    new = snapshot(root)
    assert {f: new[f] for f in FILES[:2]} == {f: old[f] for f in FILES[:2]}
    assert pq.read_schema(root / FILES[2]).metadata == {b"mgdata.data": b"zstd"}
    assert [DatasetReader(root).scene_mjb(e) for e in range(7)] == [mjb(t) for t in (*TASKS, 5)]
    assert validate_dataset(root).ok, validate_dataset(root).problems


def test_the_writer_holds_the_bases_and_the_last_file_only() -> None:
    appender = SceneAppender(per_file=2, chunks_size=1000)
    small = [bytes([k]) * 100 + b"x" for k in range(3)]  # a second MJB size, coded against its own base
    ids = []
    for k, data in enumerate([mjb(0), small[0], mjb(1), small[1], mjb(2), small[2], mjb(3)]):
        sid, appender = appender.with_scene(k, data)
        ids.append(sid)
        assert len(appender.rows) <= 2
    assert appender.with_scene(1, small[0]) == (ids[1], appender)
    assert appender.ids == set(ids) and appender.current == layout.FileRef(0, 3)
    assert sorted(appender.bases) == [101, len(mjb(0))]
    assert [r["scene"] for r in appender.rows] == [ids[6]]
    assert appender.bases[101][0] == ids[1] and appender.bases[len(mjb(0))][0] == ids[0]
    with pytest.raises(DatasetError, match="scenes_per_file must be >= 1"):
        SceneAppender(per_file=0, chunks_size=1000)


def test_an_old_layout_dataset_reads_validates_exports_copies_and_resumes(tmp_path: Path) -> None:
    root = write(tmp_path / "old", TASKS[:4])
    to_legacy_scenes(root)
    assert not (root / layout.SCENES_DIR).exists()
    assert pq.ParquetFile(root / layout.LEGACY_SCENES_PATH).num_row_groups == 1
    reader = DatasetReader(root)
    assert [reader.scene_mjb(e) for e in range(4)] == [mjb(t) for t in TASKS[:4]]
    assert rawdata.scene_model(root, reader.record(1).scene).nq > 0
    assert validate_dataset(root).ok, validate_dataset(root).problems

    v21 = export_dataset(root, tmp_path / "v21", "v2.1")
    assert (v21 / layout.LEGACY_SCENES_PATH).exists()
    assert Scenes.read(v21).mjb(reader.record(2).scene) == mjb(2)
    rendered = rerender(RenderJob(root, tmp_path / "r", size=16)).out
    assert DatasetReader(rendered).frames(3, "front").shape == (6, 16, 16, 3)
    assert validate_dataset(rendered).ok, validate_dataset(rendered).problems
    copied = repair_dataset(root, tmp_path / "copy").out  # merge's path: restaged through a new writer
    assert not (copied / layout.LEGACY_SCENES_PATH).exists()
    assert [DatasetReader(copied).scene_mjb(e) for e in range(4)] == [mjb(t) for t in TASKS[:4]]
    assert validate_dataset(copied).ok, validate_dataset(copied).problems

    legacy = (root / layout.LEGACY_SCENES_PATH).read_bytes()
    with DatasetWriter.open(root) as writer:  # resumed: new scenes go to chunked files beside the old one
        append(writer, 4, 5)
    assert (root / layout.LEGACY_SCENES_PATH).read_bytes() == legacy
    new = pq.read_table(root / layout.scenes_path(layout.FileRef())).to_pylist()
    old_base = pq.read_table(root / layout.LEGACY_SCENES_PATH).to_pylist()[0]["scene"]
    assert [(r["task_id"], r["base"]) for r in new] == [(5, old_base)]  # coded against the old file's
    reader = DatasetReader(root)
    assert reader.info["mgdata"]["scenes_per_file"] == layout.SCENES_PER_FILE
    assert [reader.scene_mjb(e) for e in range(5)] == [mjb(t) for t in (*TASKS[:4], 5)]
    assert rawdata.scene_model(root, reader.record(4).scene).nq > 0
    assert validate_dataset(root).ok, validate_dataset(root).problems


def test_a_tampered_scenes_file_is_reported_and_repair_drops_its_episodes(chunked: Path,
                                                                         tmp_path: Path) -> None:
    root = shutil.copytree(chunked, tmp_path / "ds")
    path = root / FILES[1]  # the scenes of tasks 2 and 3 (episodes 2 and 4)
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    problems = validate_dataset(root).problems
    assert f"{path}: content differs from the SHA-256 recorded in {layout.INFO_PATH} (corrupted after it " \
           "was written)" in problems
    with pytest.raises(DatasetError, match=r"file-001\.parquet: content differs"):
        DatasetWriter.open(root)
    summary = repair_dataset(root, tmp_path / "fixed")
    assert summary.dropped == (2, 4) and summary.damaged == (FILES[1],)
    fixed = DatasetReader(summary.out)
    assert [fixed.scene_mjb(e) for e in range(4)] == [mjb(t) for t in (0, 1, 1, 4)]
    assert validate_dataset(summary.out).ok, validate_dataset(summary.out).problems


def test_validate_reports_scenes_files_out_of_order_or_overfull(chunked: Path, tmp_path: Path) -> None:
    root = shutil.copytree(chunked, tmp_path / "ds")
    gone = root / FILES[1]
    moved = root / "meta/scenes/chunk-000/file-005.parquet"
    gone.rename(moved)
    info = json.loads((root / layout.INFO_PATH).read_text())
    sums = info["mgdata"]["sha256"]
    sums[str(moved.relative_to(root))] = sums.pop(FILES[1])
    info["mgdata"]["scenes_per_file"] = 1
    (root / layout.INFO_PATH).write_text(json.dumps(info))
    problems = validate_dataset(root).problems
    assert f"{moved}: out of order, the next scenes file would be {FILES[1]}" in problems
    assert f"{root / FILES[0]}: 2 scenes, expected 1 to 1 (mgdata.scenes_per_file)" in problems
