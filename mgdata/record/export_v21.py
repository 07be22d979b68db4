"""LeRobot v2.1 export: one parquet and one mp4 per episode, JSON-lines metadata.

Layout (as LeRobot 0.3.x wrote it and as openpi and GR00T N1.5 read it)::

    meta/info.json                 codebase_version "v2.1", total_chunks, total_videos, path templates
    meta/episodes.jsonl            {"episode_index", "tasks", "length"}
    meta/tasks.jsonl               {"task_index", "task"}
    meta/episodes_stats.jsonl      {"episode_index", "stats": {feature: {min, max, mean, std, count, q..}}}
    meta/stats.json                dataset stats (GR00T reads them)
    meta/mgdata_episodes.jsonl     mgdata's episode metadata (family, seed, verdict, t_violation …, scene)
    meta/scenes/chunk-*/file-*.parquet   the compiled scenes, copied as they are (``meta/scenes.parquet`` from
                                   a dataset written before chunked scenes; only with physics states)
    meta/modality.json             GR00T only
    README.md                      the view's dataset card (:mod:`mgdata.record.card`)
    data/chunk-000/episode_000000.parquet
    videos/chunk-000/<video key>/episode_000000.mp4

Each episode's video is cut from the v3.0 file at its first frame (always a keyframe) by copying packets.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from mgdata.atomic import write_text_atomic
from mgdata.record import layout
from mgdata.record.card import reader_tally, render_card
from mgdata.record.metadata import meta_to_dict
from mgdata.record.metafiles import dump_json
from mgdata.record.reader import DatasetReader
from mgdata.record.stats import stats_to_json
from mgdata.record.video import remux
from mgdata.record.views import ViewSpec, copy_scenes, rename_stats, rename_table, renamed_features

V21 = "v2.1"
CARRIED = ("spec", "hold_steps", "kept_only", "attempts", "generator", "physics_gate", "recovery",
           "rendered_from")
"""The source's ``mgdata`` block entries a v2.1 export keeps (what it is and how it was made; not the v3.0
writer's settings or checksums), in the source's order."""
V21_DATA_PATH = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
V21_VIDEO_PATH = "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4"


def _jsonl(path: Path, rows: list[dict]) -> None:
    path.write_text("".join(json.dumps(r, ensure_ascii=False, allow_nan=False) + "\n" for r in rows))


def modality(reader: DatasetReader, view: ViewSpec) -> dict:
    """GR00T's ``meta/modality.json``: arm joints and gripper as separate groups, videos, task annotation."""
    n_arm = len(reader.schema.state_names) - 1
    groups = {"single_arm": {"start": 0, "end": n_arm}, "gripper": {"start": n_arm, "end": n_arm + 1}}
    return {
        "state": groups,
        "action": groups,
        "video": {layout.camera_name(new): {"original_key": new} for new in view.cameras.values()},
        "annotation": {"human.task_description": {"original_key": "task_index"}},
    }


def write_v21(reader: DatasetReader, out: Path, view: ViewSpec) -> None:
    """Write the view of ``reader``'s dataset in the v2.1 layout into the (empty) folder ``out``."""
    chunks_size = int(reader.info["chunks_size"])
    fps = reader.schema.fps
    episodes, ep_stats, ep_meta = [], [], []
    file_start: dict[layout.FileRef, int] = {}
    for rec in reader.records():
        chunk = rec.index // chunks_size
        data = reader.data_table(rec.data)
        offset = rec.from_index - file_start.setdefault(rec.data, rec.from_index)
        rows = rename_table(data.slice(offset, rec.length), view)
        path = out / V21_DATA_PATH.format(episode_chunk=chunk, episode_index=rec.index)
        path.parent.mkdir(parents=True, exist_ok=True)
        layout.write_data_file(rows, path)
        for cam, new in view.cameras.items():
            src, start = reader.video_file(rec.index, cam)
            dst = out / V21_VIDEO_PATH.format(episode_chunk=chunk, video_key=new, episode_index=rec.index)
            dst.parent.mkdir(parents=True, exist_ok=True)
            remux([(src, start, rec.length)], dst, fps)
        episodes.append({"episode_index": rec.index, "tasks": [rec.task], "length": rec.length})
        ep_stats.append({"episode_index": rec.index, "stats": rename_stats(stats_to_json(rec.stats), view)})
        scene = {"scene": rec.scene} if view.physics and rec.scene is not None else {}
        ep_meta.append({"episode_index": rec.index, **meta_to_dict(rec.meta), **scene})
    meta = out / "meta"
    meta.mkdir(parents=True, exist_ok=True)
    _jsonl(meta / "episodes.jsonl", episodes)
    _jsonl(meta / "tasks.jsonl", [{"task_index": i, "task": t} for i, t in enumerate(reader.tasks)])
    _jsonl(meta / "episodes_stats.jsonl", ep_stats)
    _jsonl(meta / "mgdata_episodes.jsonl", ep_meta)
    copy_scenes(reader, out, view)
    stats = json.loads(reader.files.path(layout.STATS_PATH).read_text())
    (meta / "stats.json").write_text(dump_json(rename_stats(stats, view)))
    n = reader.num_episodes
    info = {
        "codebase_version": V21, "robot_type": reader.info["robot_type"], "total_episodes": n,
        "total_frames": reader.num_frames, "total_tasks": len(reader.tasks),
        "total_videos": n * len(view.cameras), "total_chunks": math.ceil(n / chunks_size),
        "chunks_size": chunks_size, "fps": fps, "splits": {"train": f"0:{n}"},
        "data_path": V21_DATA_PATH, "video_path": V21_VIDEO_PATH if view.cameras else None,
        "features": renamed_features(reader, view),
        "mgdata": {**{k: v for k, v in reader.info["mgdata"].items() if k in CARRIED},
                   "exported_from": layout.CODEBASE_VERSION, "exported_as": view.name},
    }
    (meta / "info.json").write_text(dump_json(info))
    if view.modality:
        (meta / "modality.json").write_text(dump_json(modality(reader, view)))
    write_text_atomic(out / layout.CARD_PATH, render_card(info, reader.tasks, reader_tally(reader)))
