"""Loader views: the dataset re-keyed for a model family's fine-tuning code, written as a new dataset.

``mgdata export DATASET OUT --format F`` picks cameras and renames keys per convention; video packets are
copied, never re-encoded, so frames are bit-identical to the source:

- ``smolvla``: LeRobot v3.0 with ``observation.images.top`` (an overview camera) and
  ``observation.images.wrist``, as the SmolVLA fine-tuning recipes expect.
- ``pi0`` (pi0 / pi0.5 via openpi, which reads LeRobot v2.1): v2.1 with openpi's LIBERO-style keys
  ``image`` (overview), ``wrist_image``, ``state``, ``actions``.
- ``groot`` (GR00T N1.5, LeRobot v2.1 + ``meta/modality.json``): every camera (or ``--cameras``), state and
  action split into ``single_arm`` (0:7) and ``gripper`` (7:8), the task from ``task_index``.
- ``v2.1``: the whole dataset in the LeRobot v2.1 layout, for readers pinned to it.
- ``state``: LeRobot v3.0 without cameras and without the per-frame labels, DFA states and violation flags
  (``safety.engaged`` and ``safety.success`` stay), with ``observation.environment_state`` derived from the
  stored physics states (:mod:`mgdata.record.environment_view`): what a state-only policy trains on without
  LeRobot decoding every video of every sample. ``add_environment_state`` adds the feature to ``smolvla``.

Episode metadata (verdicts, violation times) travels with every view and the per-frame safety columns with
every view but ``state``: LeRobot's ``__getitem__`` converts every column of the action chunk it reads, and
the three safety vectors, which no policy reads, made a state-only sample 1.7x dearer (5.8 → 3.4 CPU-ms,
jar; docs/train.md). The source dataset keeps them. The simulator state (``sim.physics_state``
and the compiled scenes, ``meta/scenes/…``) travels with ``v2.1`` only: the training views drop it,
since their loaders take every non-video feature as a model input or expect a fixed key set, and a policy
must not see simulator state.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.atomic import write_text_atomic
from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.card import reader_tally, render_card
from mgdata.record.commit import sha256_file
from mgdata.record.episode import DatasetSchema
from mgdata.record.episodes import HISTOGRAM_PREFIX, SCENE_COLUMN
from mgdata.record.metafiles import dump_json
from mgdata.record.reader import DatasetReader, read_parquet
from mgdata.record.scenes import scene_files
from mgdata.sim.environment_state import FEATURE

FORMATS = ("v2.1", "pi0", "smolvla", "groot", "state")


@dataclass(frozen=True)
class ViewSpec:
    """How an export selects and renames features.

    Attributes:
        version: output layout, ``"v3.0"`` or ``"v2.1"``.
        cameras: source camera → output video key, in output order (unlisted cameras are dropped).
        renames: source feature key → output key for non-video features (others keep their key).
        modality: write GR00T's ``meta/modality.json``.
        physics: keep ``sim.physics_state`` and the compiled scenes.
        environment_state: add ``observation.environment_state`` (v3.0 views only).
        safety: keep the per-frame labels, DFA states and violation flags (engagement and success stay in
            every view).
        name: the export format (:data:`FORMATS`), recorded as ``mgdata.exported_as`` in the view's
            ``info.json`` and named by its card.
    """

    version: str
    cameras: dict[str, str]
    renames: dict[str, str] = field(default_factory=dict)
    modality: bool = False
    physics: bool = False
    environment_state: bool = False
    safety: bool = True
    name: str = ""

    def key(self, source: str) -> str | None:
        """The output key of a source feature key, ``None`` if the view drops it."""
        if source.startswith(layout.IMAGE_PREFIX):
            return self.cameras.get(layout.camera_name(source))
        if source in (layout.PHYSICS_STATE, layout.EXECUTED_ACTION) and not self.physics:
            return None
        if source in layout.SAFETY_VECTORS and not self.safety:
            return None
        return self.renames.get(source, source)


def _pick(schema: DatasetSchema, name: str | None, role: str, wrist: bool) -> str:
    if name is not None:
        if name not in schema.cameras:
            raise DatasetError(f"--{role} {name!r} is not a camera of this dataset "
                               f"({', '.join(schema.cameras)})")
        return name
    if wrist:
        if "wrist" in schema.cameras:
            return "wrist"
        raise DatasetError(f"no camera named 'wrist' ({', '.join(schema.cameras)}); pass --wrist")
    others = [c for c in schema.cameras if c != "wrist"]
    if not others:
        raise DatasetError("the dataset has no overview camera; pass --overview")
    return others[0]


def view_for(fmt: str, schema: DatasetSchema, *, overview: str | None = None, wrist: str | None = None,
             cameras: tuple[str, ...] | None = None) -> ViewSpec:
    """The :class:`ViewSpec` of export format ``fmt`` (one of :data:`FORMATS`)."""
    if fmt not in FORMATS:
        raise DatasetError(f"export format {fmt!r} is unknown; expected one of {', '.join(FORMATS)}")
    if fmt == "state":
        return ViewSpec("v3.0", {}, environment_state=True, safety=False, name=fmt)
    if fmt in ("pi0", "smolvla"):
        over, wri = _pick(schema, overview, "overview", False), _pick(schema, wrist, "wrist", True)
        if over == wri:
            raise DatasetError(f"the overview and wrist cameras are both {over!r}")
        if fmt == "pi0":
            return ViewSpec("v2.1", {over: "image", wri: "wrist_image"},
                            {layout.STATE: "state", layout.ACTION: "actions"}, name=fmt)
        return ViewSpec("v3.0", {over: layout.video_key("top"), wri: layout.video_key("wrist")}, name=fmt)
    chosen = cameras or schema.cameras
    unknown = [c for c in chosen if c not in schema.cameras]
    if unknown:
        raise DatasetError(f"--cameras {unknown} are not cameras of this dataset "
                           f"({', '.join(schema.cameras)})")
    return ViewSpec("v2.1", {c: layout.video_key(c) for c in chosen}, modality=fmt == "groot",
                    physics=fmt == "v2.1", name=fmt)


def renamed_features(reader: DatasetReader, view: ViewSpec) -> dict:
    """``info.json`` features of the view, in source order with cameras in view order."""
    feats = reader.info["features"]
    out: dict = {}
    for key, ft in feats.items():
        if ft["dtype"] != "video" and key not in layout.INDEX_COLUMNS and view.key(key) is not None:
            out[view.key(key)] = ft
    for cam, new in view.cameras.items():
        out[new] = feats[layout.video_key(cam)]
    out.update({k: feats[k] for k in layout.INDEX_COLUMNS})
    return out


def rename_stats(stats: dict, view: ViewSpec) -> dict:
    return {view.key(k): v for k, v in stats.items() if view.key(k) is not None}


def _rename_column(name: str, view: ViewSpec) -> str | None:
    """Episodes-table column under the view (``videos/<k>/…``, ``stats/<k>/…``, histograms, scene)."""
    if name == SCENE_COLUMN:
        return name if view.physics else None
    for prefix in ("videos/", "stats/", HISTOGRAM_PREFIX):
        if name.startswith(prefix):
            key, _, rest = name[len(prefix):].partition("/")
            new = view.key(key)
            return None if new is None else prefix + new + ("/" + rest if rest else "")
    return name


def rename_table(table: pa.Table, view: ViewSpec, episodes: bool = False) -> pa.Table:
    names = [(_rename_column(n, view) if episodes else view.key(n)) for n in table.column_names]
    keep = [i for i, n in enumerate(names) if n is not None]
    return pa.Table.from_arrays([table.column(i) for i in keep], names=[names[i] for i in keep])


def copy_scenes(reader: DatasetReader, out: Path, view: ViewSpec,
                target: Callable[[str], Path] | None = None) -> None:
    """Copy the scenes files as they are (either layout, :func:`~mgdata.record.scenes.scene_files`) if the
    view keeps the physics state."""
    if not view.physics:
        return
    for rel in scene_files(reader.files):
        dst = target(rel) if target else out / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(reader.files.path(rel), dst)


def _insert_after(features: dict, after: str, key: str, value: dict) -> dict:
    out: dict = {}
    for k, v in features.items():
        out[k] = v
        if k == after:
            out[key] = value
    return out


def write_v30_view(reader: DatasetReader, out: Path, view: ViewSpec) -> None:
    """A v3.0 dataset with the view's cameras and keys (files copied or re-keyed, never re-encoded), and
    its own card (:mod:`mgdata.record.card`)."""
    from mgdata.record.environment_view import EnvironmentStates

    records = reader.records()
    written: list[str] = []
    env = EnvironmentStates(reader) if view.environment_state else None

    def target(rel: str) -> Path:
        path = out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        written.append(rel)
        return path

    for ref in sorted({r.data for r in records}):
        rel = layout.data_path(ref)
        table = read_parquet(reader.files.path(rel))
        layout.write_data_file(rename_table(env.add_to_data(table) if env else table, view), target(rel))
    for ref in sorted({r.meta_file for r in records}):
        rel = layout.episodes_path(ref)
        table = read_parquet(reader.files.path(rel))
        table = env.add_to_episodes(table) if env else table
        pq.write_table(rename_table(table, view, episodes=True), target(rel))
    for cam, new in view.cameras.items():
        for ref in sorted({r.videos[layout.video_key(cam)].ref for r in records}):
            src = reader.files.path(layout.video_path(layout.video_key(cam), ref))
            shutil.copyfile(src, target(layout.video_path(new, ref)))
    copy_scenes(reader, out, view, target)
    shutil.copyfile(reader.files.path(layout.TASKS_PATH), target(layout.TASKS_PATH))
    stats = json.loads(reader.files.path(layout.STATS_PATH).read_text())
    stats = rename_stats(stats, view)
    features = renamed_features(reader, view)
    if env is not None:
        stats[FEATURE] = {k: v.tolist() for k, v in env.dataset_stats().items()}
        features = _insert_after(features, layout.STATE, FEATURE, env.feature())
    target(layout.STATS_PATH).write_text(dump_json(stats))
    info = dict(reader.info, features=features)
    info["mgdata"] = dict(info["mgdata"], exported_as=view.name,
                          sha256={rel: sha256_file(out / rel) for rel in sorted(written)})
    (out / layout.INFO_PATH).write_text(dump_json(info))
    write_text_atomic(out / layout.CARD_PATH, render_card(info, reader.tasks, reader_tally(reader)))
