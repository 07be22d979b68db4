"""``mgdata validate``: check a dataset's structure, counts, timestamps, stats, safety record and card.

Every problem is one line naming the file or episode; nothing raises past :func:`validate_dataset` for a
corrupt dataset. Work left by an interrupted writer (staged episodes, an uncommitted or not yet installed
commit) is reported as a note: the dataset is valid up to its last complete episode.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from mgdata.errors import DatasetError, MgdataError
from mgdata.record import layout
from mgdata.record.audit import SafetyAuditor
from mgdata.record.card import card_of
from mgdata.record.command_audit import audit_commands
from mgdata.record.commit import sha256_file
from mgdata.record.episodes import EpisodeRecord, stats_features
from mgdata.record.frontmatter import card_problem
from mgdata.record.physics_audit import PhysicsAuditor, PhysicsGate
from mgdata.record.reader import DatasetReader, EpisodeData
from mgdata.record.scenes import Scenes, scene_files, scenes_file_ref
from mgdata.record.stats import STAT_KEYS, FeatureStats, image_stats, merge_stats, numeric_stats
from mgdata.record.video import check_decodes, decode, probe
from mgdata.tasks.recovery import recovery_from_info

_ERRORS = (MgdataError, OSError, ValueError, KeyError, TypeError, IndexError, pa.ArrowException)


@dataclass
class ValidationReport:
    """What :func:`validate_dataset` found; ``ok`` when there are no problems (notes are informational)."""

    root: Path
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    episodes: int = 0
    frames: int = 0

    @property
    def ok(self) -> bool:
        return not self.problems


def validate_dataset(root: Path, *, decode_all: bool = False) -> ValidationReport:
    """Validate the dataset at ``root``. ``decode_all`` decodes every video frame (default: demux every
    packet and decode each episode's first frame)."""
    report = ValidationReport(Path(root))
    try:
        reader = DatasetReader(Path(root))
    except _ERRORS as err:
        report.problems.append(str(err))
        return report
    report.episodes, report.frames = reader.num_episodes, reader.num_frames
    if reader.files.pending_commit:
        report.notes.append("a committed episode is not yet installed (writer killed mid-install); read "
                            "through its commit manifest; the next DatasetWriter.open finishes it")
    if reader.files.writer_active:
        report.notes.append("a writer is appending to this dataset right now; validated up to its last "
                            "commit")
    else:
        for rel in reader.files.leftovers:
            report.notes.append(f"{rel}: uncommitted work of an interrupted writer (ignored; removed on the "
                                "next DatasetWriter.open)")
    records = reader.records()
    _guard(report, lambda: _check_info(reader, report))
    _guard(report, lambda: _check_index(reader, records, report))
    values = _guard(report, lambda: _check_data(reader, records, report)) or {}
    for key in [layout.video_key(c) for c in reader.schema.cameras]:
        _guard(report, lambda key=key: _check_videos(reader, records, key, decode_all, report))
    _guard(report, lambda: _check_stats(reader, records, values, report))
    _guard(report, lambda: _check_scenes(reader, records, report))
    _guard(report, lambda: _check_physics(reader, records, report))
    _guard(report, lambda: _check_commands(reader, records, report))
    _guard(report, lambda: _check_unreferenced(reader, records, report))
    _guard(report, lambda: _check_checksums(reader, report))
    _guard(report, lambda: _check_card(reader, report))
    return report


def _guard(report: ValidationReport, check: Callable[[], object]) -> object:
    try:
        return check()
    except _ERRORS as err:
        report.problems.append(str(err))
        return None


def _check_info(reader: DatasetReader, report: ValidationReport) -> None:
    feats = reader.info["features"]
    where = reader.files.path(layout.INFO_PATH)
    for col in layout.all_columns(reader.schema):
        ft = feats.get(col.key)
        if ft is None or ft.get("dtype") != col.dtype or list(ft.get("shape", [])) != [col.width]:
            report.problems.append(f"{where}: feature {col.key!r} is {ft}, expected dtype {col.dtype} shape "
                                   f"[{col.width}]")
    if reader.info["total_tasks"] != len(reader.tasks):
        report.problems.append(f"{where}: total_tasks {reader.info['total_tasks']}, "
                               f"{layout.TASKS_PATH} has {len(reader.tasks)}")
    if reader.num_episodes and reader.info.get("splits", {}).get("train") != f"0:{reader.num_episodes}":
        report.problems.append(f"{where}: splits {reader.info.get('splits')} do not cover the "
                               f"{reader.num_episodes} episodes")


def _check_index(reader: DatasetReader, records: list[EpisodeRecord], report: ValidationReport) -> None:
    start = 0
    for rec in records:
        where = f"episode {rec.index}"
        if rec.length <= 0:
            report.problems.append(f"{where}: length {rec.length}")
        if rec.from_index != start:
            report.problems.append(f"{where}: dataset_from_index {rec.from_index}, expected {start}")
        if rec.task not in reader.tasks:
            report.problems.append(f"{where}: task {rec.task!r} is not in {layout.TASKS_PATH}")
        start = rec.from_index + rec.length
    if start != reader.num_frames:
        report.problems.append(f"{reader.files.path(layout.INFO_PATH)}: total_frames {reader.num_frames}, "
                               f"the episodes hold {start}")


def _check_data(reader: DatasetReader, records: list[EpisodeRecord],
                report: ValidationReport) -> dict[str, list[np.ndarray]]:
    """Row layout of each data file, per-episode columns, and the safety audit; returns all values."""
    cols = layout.all_columns(reader.schema)
    values: dict[str, list[np.ndarray]] = {c.key: [] for c in cols}
    expected_schema = layout.data_arrow_schema(reader.schema)
    auditor = SafetyAuditor(reader.schema.propositions, reader.spec, hold_steps=reader.hold_steps,
                            kept_only=reader.kept_only)
    fps = reader.schema.fps
    for ref in sorted({r.data for r in records}):
        path = reader.files.path(layout.data_path(ref))
        try:
            table = reader.data_table(ref)
        except _ERRORS as err:
            report.problems.append(str(err))
            continue
        for f in expected_schema:
            got = table.schema.field(f.name).type if f.name in table.column_names else None
            if got != f.type:
                report.problems.append(f"{path}: column {f.name!r} has type {got}, expected {f.type}")
        in_file = [r for r in records if r.data == ref]
        if table.num_rows != sum(r.length for r in in_file):
            report.problems.append(f"{path}: {table.num_rows} rows, its episodes "
                                   f"{[r.index for r in in_file]} hold {sum(r.length for r in in_file)}")
        offset = 0
        for rec in in_file:
            rows = table.slice(offset, rec.length)
            offset += rec.length
            got = {c.key: c.from_arrow(rows.column(c.key)) for c in cols if c.key in rows.column_names}
            task = reader.tasks.index(rec.task) if rec.task in reader.tasks else -1
            expect = {
                "index": np.arange(rec.from_index, rec.to_index), "frame_index": np.arange(rec.length),
                "episode_index": np.full(rec.length, rec.index),
                "timestamp": layout.timestamps(rec.length, fps), "task_index": np.full(rec.length, task),
            }
            for key, want in expect.items():
                have = got.get(key)
                if have is None or len(have) != rec.length or not np.array_equal(have[:, 0], want):
                    report.problems.append(f"{path}: episode {rec.index}: column {key!r} is not "
                                           f"{_describe(key)}")
            for key, arr in got.items():
                values[key].append(arr)
            try:
                report.problems += auditor.audit(reader.episode(rec.index))
            except _ERRORS as err:
                report.problems.append(f"episode {rec.index}: {err}")
    return values


def _describe(key: str) -> str:
    return {"index": "the episode's contiguous global frame range", "frame_index": "0..length-1",
            "episode_index": "the episode index", "timestamp": "frame_index / fps (float32)",
            "task_index": "the index of the episode's task"}[key]


def _check_videos(reader: DatasetReader, records: list[EpisodeRecord], key: str, decode_all: bool,
                  report: ValidationReport) -> None:
    s = reader.schema
    for ref in sorted({r.videos[key].ref for r in records}):
        path = reader.files.path(layout.video_path(key, ref))
        in_file = [r for r in records if r.videos[key].ref == ref]
        starts, offset = [], 0
        for rec in in_file:
            span = rec.videos[key]
            if abs(span.from_timestamp - offset / s.fps) > 1e-9 or \
                    abs(span.to_timestamp - (offset + rec.length) / s.fps) > 1e-9:
                report.problems.append(f"episode {rec.index}: {key} spans {span.from_timestamp}.."
                                       f"{span.to_timestamp} s, expected {offset / s.fps}.."
                                       f"{(offset + rec.length) / s.fps} s")
            starts.append(offset)
            offset += rec.length
        try:
            info = probe(path, s.fps)
        except _ERRORS as err:
            report.problems.append(str(err))
            continue
        if (info.width, info.height) != (s.image_width, s.image_height):
            report.problems.append(f"{path}: frames are {info.width}x{info.height}, expected "
                                   f"{s.image_width}x{s.image_height}")
        if info.frames != offset or not np.array_equal(info.frame_indices, np.arange(info.frames)):
            report.problems.append(f"{path}: {info.frames} frames (timestamps "
                                   f"{_ts_summary(info.frame_indices)}), its episodes "
                                   f"{[r.index for r in in_file]} need {offset} at 0..{offset - 1}")
            continue
        not_key = [rec.index for rec, st in zip(in_file, starts, strict=True) if not info.keyframes[st]]
        if not_key:
            report.problems.append(f"{path}: episodes {not_key} do not start on a keyframe")
        try:
            if decode_all:
                check_decodes(path, offset, s.fps)
            else:
                for st in starts:
                    decode(path, st, 1, s.fps)
        except _ERRORS as err:
            report.problems.append(str(err))


def _ts_summary(idx: np.ndarray) -> str:
    return "none" if len(idx) == 0 else f"{idx[0]}..{idx[-1]}"


def _check_stats(reader: DatasetReader, records: list[EpisodeRecord], values: dict[str, list[np.ndarray]],
                 report: ValidationReport) -> None:
    """Per episode, the stats equal the ones computed from its frames (pixel histograms for images); the
    dataset stats are the episodes' stats merged in order (:func:`merge_stats`: what the writer stores),
    and their count, min, max, mean and std equal the ones computed from all frames at once."""
    if not records:
        return
    where = reader.files.path(layout.STATS_PATH)
    stored = reader.stats()
    s = reader.schema
    hist_sum = {k: sum(r.histograms[k] for r in records) for k in records[0].histograms}
    complete = all(len(values[c.key]) == len(records) and
                   sum(len(v) for v in values[c.key]) == reader.num_frames for c in layout.all_columns(s))
    for rec in records:
        for key, image in stats_features(s):
            problem = _stats_sanity(rec.stats[key], image, rec.length)
            if problem:
                report.problems.append(f"episode {rec.index}: stats/{key}: {problem}")
            elif image and not _close(rec.stats[key], image_stats(rec.histograms[key], rec.length)):
                report.problems.append(f"episode {rec.index}: stats/{key} differ from its pixel histogram")
            elif not image and complete and \
                    not _close(rec.stats[key], numeric_stats(values[key][rec.index])):
                report.problems.append(f"episode {rec.index}: stats/{key} differ from its frames")
    for key, image in stats_features(s):
        fs = stored.get(key)
        if fs is None:
            report.problems.append(f"{where}: no stats for {key!r}")
            continue
        problem = _stats_sanity(fs, image, reader.num_frames)
        if problem:
            report.problems.append(f"{where}: {key}: {problem}")
            continue
        if image:
            if not _close(fs, image_stats(hist_sum[key], reader.num_frames)):
                report.problems.append(f"{where}: {key} stats differ from the ones of the pixel histograms")
            continue
        merged = None
        for rec in records:
            merged = merge_stats(merged, rec.stats[key])
        assert merged is not None
        if not _close(fs, merged):
            report.problems.append(f"{where}: {key} stats differ from the episodes' stats merged in order")
        elif complete and not _close(fs, numeric_stats(np.concatenate(values[key])), keys=_MOMENTS):
            report.problems.append(f"{where}: {key} count, min, max, mean or std differ from the ones "
                                   "computed from the data")


_MOMENTS = ("min", "max", "mean", "std", "count")


def _stats_sanity(fs: FeatureStats, image: bool, count: int) -> str | None:
    missing = [k for k in STAT_KEYS if k not in fs]
    if missing:
        return f"missing {missing}"
    shape = fs["mean"].shape
    if image and shape != (3, 1, 1):
        return f"shape {shape}, expected (3, 1, 1)"
    if any(fs[k].shape != shape for k in STAT_KEYS if k != "count") or fs["count"].shape != (1,):
        return "inconsistent shapes"
    if int(fs["count"][0]) != count:
        return f"count {int(fs['count'][0])}, expected {count}"
    arr = {k: fs[k].astype(np.float64) for k in STAT_KEYS}
    if not all(np.all(np.isfinite(v)) for v in arr.values()):
        return "non-finite values"
    order = ["min", "q01", "q10", "q50", "q90", "q99", "max"]
    if any(np.any(arr[a] > arr[b] + 1e-9) for a, b in itertools.pairwise(order)):
        return "quantiles out of order (expected min <= q01 <= ... <= q99 <= max)"
    if np.any(arr["mean"] < arr["min"] - 1e-9) or np.any(arr["mean"] > arr["max"] + 1e-9) or \
            np.any(arr["std"] < 0):
        return "mean outside [min, max] or negative std"
    if image and (np.any(arr["min"] < 0) or np.any(arr["max"] > 1)):
        return "image stats outside [0, 1]"
    return None


def _close(a: FeatureStats, b: FeatureStats, keys: tuple[str, ...] = STAT_KEYS) -> bool:
    return all(np.allclose(np.asarray(a[k], np.float64), np.asarray(b[k], np.float64), rtol=1e-6, atol=1e-9)
               for k in keys)


def _check_scenes(reader: DatasetReader, records: list[EpisodeRecord], report: ValidationReport) -> None:
    """Every episode's compiled scene decodes, loads in MuJoCo and has the stored physics-state width; every
    stored scene is used; the scenes files are in order (:func:`_check_scene_files`)."""
    if reader.physics_spec is None:
        for rel in scene_files(reader.files):
            report.problems.append(f"{reader.root / rel}: scenes in a dataset without {layout.PHYSICS_STATE}")
        return
    import mujoco

    scenes = reader.scenes()
    _check_scene_files(reader, scenes, report)
    width = reader.schema.physics_state_size
    used = sorted({r.scene for r in records if r.scene is not None})
    for scene in used:
        first = next(r.index for r in records if r.scene == scene)
        try:
            model = mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": scenes.mjb(scene)})
        except (DatasetError, ValueError) as err:
            report.problems.append(f"episode {first}: its scene {scene!r} is not a loadable MuJoCo model "
                                   f"({err})")
            continue
        size = mujoco.mj_stateSize(model, reader.physics_spec)
        if size != width:
            report.problems.append(f"episode {first}: its scene {scene!r} has a physics state of {size} "
                                   f"values, {layout.PHYSICS_STATE} has {width}")
    for scene in scenes.ids:
        if scene not in used:
            report.problems.append(f"{reader.root / scenes.row(scene).file}: scene {scene!r} is not used by "
                                   "any episode")


def _check_scene_files(reader: DatasetReader, scenes: Scenes, report: ValidationReport) -> None:
    """The chunked scenes files are numbered in order from ``chunk-000/file-000`` (as data files roll over)
    and hold at most ``mgdata.scenes_per_file`` scenes each (the legacy single file: any number)."""
    per_file = reader.info["mgdata"].get("scenes_per_file") or layout.SCENES_PER_FILE
    held = {rel: 0 for rel in scene_files(reader.files)}
    for row in scenes.rows:
        held[row.file] += 1
    expected = layout.FileRef()
    for rel, n in held.items():
        ref = scenes_file_ref(rel)
        if ref is None:
            continue
        if ref != expected:
            report.problems.append(f"{reader.root / rel}: out of order, the next scenes file would be "
                                   f"{layout.scenes_path(expected)}")
        expected = ref.next(int(reader.info["chunks_size"]))
        if not 1 <= n <= per_file:
            report.problems.append(f"{reader.root / rel}: {n} scenes, expected 1 to {per_file} "
                                   "(mgdata.scenes_per_file)")


def _check_commands(reader: DatasetReader, records: list[EpisodeRecord], report: ValidationReport) -> None:
    """A perturbed dataset's executed commands (:mod:`mgdata.record.command_audit`): what its states were
    stepped with, within the recorded amplitude of the actions."""
    if not reader.schema.executed_action or reader.physics_spec is None:
        return
    recovery = recovery_from_info(reader.info, str(reader.root / layout.INFO_PATH))
    if recovery is None:
        report.problems.append(f"{reader.root / layout.INFO_PATH}: the dataset stores "
                               f"{layout.EXECUTED_ACTION} but no mgdata.recovery (mode, amplitude)")
    amplitude = recovery.amplitude if recovery else None
    _audit_episodes(reader, records, report, "command audit",
                    lambda ep, model: audit_commands(ep, model, amplitude))


def _audit_episodes(reader: DatasetReader, records: list[EpisodeRecord], report: ValidationReport, name: str,
                    audit: Callable[[EpisodeData, Any], list[str]]) -> None:
    """``audit(episode, model)`` of every episode with a scene (each scene's model built once), its
    problems (or its error, as ``episode i: <name>: …``) into ``report``."""
    from mgdata.record.physics import model_from_bytes  # MuJoCo only for datasets that store its state

    scenes, models = reader.scenes(), {}
    for rec in records:
        if rec.scene is None:
            continue
        try:
            if rec.scene not in models:
                models[rec.scene] = model_from_bytes(scenes.mjb(rec.scene))
            report.problems += audit(reader.episode(rec.index), models[rec.scene])
        except _ERRORS as err:
            report.problems.append(f"episode {rec.index}: {name}: {err}")


def _check_physics(reader: DatasetReader, records: list[EpisodeRecord], report: ValidationReport) -> None:
    """The physics audit (:mod:`mgdata.record.physics_audit`) of every episode against the gate's bounds in
    ``info.json``, from the stored scenes and states; a note gives the dataset's deepest contact."""
    gate = PhysicsGate.from_info(reader.info, str(reader.root / layout.INFO_PATH))
    if gate is None or reader.physics_spec is None:
        return
    auditor = PhysicsAuditor(gate, hold_steps=reader.hold_steps, fps=reader.schema.fps)
    _audit_episodes(reader, records, report, "physics audit", auditor.audit)
    measured = [r for r in records if r.meta.max_penetration is not None]
    if measured:
        worst = max(measured, key=lambda r: r.meta.max_penetration or 0.0)
        m = worst.meta
        bodies = m.penetration_bodies or "no overlap"
        report.notes.append(f"deepest contact: {(m.max_penetration or 0.0) * 1000:.2f} mm (episode "
                            f"{worst.index}, frame {m.penetration_step}, {bodies}); kept demos may reach "
                            f"{gate.max_penetration * 1000:.2f} mm")


def _check_unreferenced(reader: DatasetReader, records: list[EpisodeRecord],
                        report: ValidationReport) -> None:
    used = {layout.data_path(r.data) for r in records} | {layout.episodes_path(r.meta_file) for r in records}
    used |= {layout.video_path(k, span.ref) for r in records for k, span in r.videos.items()}
    for pattern in ("data/*/*.parquet", layout.EPISODES_DIR + "/*/*.parquet", "videos/*/*/*.mp4"):
        for rel in reader.files.glob(pattern):
            if rel not in used:
                report.problems.append(f"{reader.root / rel}: not referenced by any episode (LeRobot would "
                                       "still load data files)")


def _check_checksums(reader: DatasetReader, report: ValidationReport) -> None:
    recorded = reader.info["mgdata"].get("sha256", {})
    for rel, digest in recorded.items():
        path = reader.files.path(rel)
        if not path.exists():
            report.problems.append(f"{reader.root / rel}: missing")
        elif sha256_file(path) != digest:
            report.problems.append(f"{reader.root / rel}: content differs from the SHA-256 recorded in "
                                   f"{layout.INFO_PATH} (corrupted after it was written)")
    if reader.num_episodes:
        scenes = scene_files(reader.files) if reader.physics_spec is not None else []
        for rel in [layout.STATS_PATH, layout.TASKS_PATH, *scenes]:
            if rel not in recorded:
                report.problems.append(f"{reader.root / rel}: no checksum recorded in {layout.INFO_PATH}")


def _check_card(reader: DatasetReader, report: ValidationReport) -> None:
    """The dataset card (``README.md``, :mod:`mgdata.record.card`) is a Hub card and the one mgdata renders
    for the dataset as it is now; a dataset written before cards (none) gets a note."""
    where, path = reader.root / layout.CARD_PATH, reader.files.path(layout.CARD_PATH)
    if not path.is_file():
        report.notes.append(f"{where}: no dataset card (written before mgdata wrote cards); write one with: "
                            f"mgdata card {reader.root}")
        return
    fix = f"rewrite it with: mgdata card {reader.root}"
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        report.problems.append(f"{where}: not UTF-8 text; {fix}")
        return
    problem = card_problem(text)
    if problem is not None:
        report.problems.append(f"{where}: not a Hugging Face dataset card ({problem}); {fix}")
    elif text != card_of(reader):
        report.problems.append(f"{where}: differs from the card of the dataset as it is now (edited by hand, "
                               f"or left by an interrupted write); {fix}")
