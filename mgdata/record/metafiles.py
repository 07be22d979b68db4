"""The small meta files: ``meta/info.json``, ``meta/tasks.parquet`` and ``meta/stats.json``.

``info.json`` is LeRobot's (version, totals, path templates, features) plus an ``mgdata`` block holding the
full safety spec (constraints with formulas, propositions with evaluators) and mgdata's writer settings.
The :class:`~mgdata.record.episode.DatasetSchema` is read back from the features, so there is one source
of truth for it.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from mgdata.errors import DatasetError, SpecError
from mgdata.record import layout
from mgdata.record.episode import DatasetSchema
from mgdata.record.video import VideoSettings
from mgdata.spec import SafetySpec, spec_from_mapping

MGDATA_FORMAT = 1
_REQUIRED = ("codebase_version", "fps", "features", "total_episodes", "total_frames", "total_tasks",
             "data_path", "video_path", "chunks_size")


def spec_to_dict(spec: SafetySpec) -> dict[str, Any]:
    """The spec as the table :func:`mgdata.spec.spec_from_mapping` reads (recipes use the same shape)."""
    return {
        "name": spec.name,
        "constraints": [{"id": c.id, "formula": c.formula, "description": c.description}
                        for c in spec.constraints],
        "propositions": {p.name: {"evaluator": p.evaluator, "subjects": list(p.subjects),
                                  "params": dict(p.params), "quantifier": p.quantifier}
                         for p in spec.propositions},
    }


def spec_from_dict(data: Mapping[str, Any], where: str) -> SafetySpec:
    """Rebuild (and re-validate) the spec stored in ``info.json``."""
    try:
        return spec_from_mapping(data, f"{where}: mgdata.spec")
    except SpecError as err:
        raise DatasetError(str(err)) from None


def build_info(schema: DatasetSchema, video: VideoSettings, spec: SafetySpec | None, *, chunks_size: int,
               data_file_mb: int, video_file_mb: int, video_file_seconds: float,
               hold_steps: int | None = None, kept_only: bool = False,
               episodes_per_file: int | None = None,
               scenes_per_file: int = layout.SCENES_PER_FILE) -> dict[str, Any]:
    """A new dataset's ``info.json`` (no episodes yet).

    ``hold_steps`` (the gate's success window) and ``kept_only`` (the dataset promises only kept episodes)
    are what ``mgdata validate`` audits every episode against.
    """
    features: dict[str, Any] = {c.key: c.feature() for c in layout.frame_columns(schema)}
    if schema.physics_state_size:
        from mgdata.record.physics import feature_info  # MuJoCo only for datasets that store its state

        features[layout.PHYSICS_STATE]["info"] = feature_info()
    for cam in schema.cameras:
        features[layout.video_key(cam)] = {
            "dtype": "video", "shape": [schema.image_height, schema.image_width, 3],
            "names": ["height", "width", "channels"],
            "info": video.info(schema.fps, schema.image_height, schema.image_width),
        }
    features.update({c.key: c.feature() for c in layout.index_columns()})
    return {
        "codebase_version": layout.CODEBASE_VERSION, "robot_type": schema.robot_type,
        "total_episodes": 0, "total_frames": 0, "total_tasks": 0, "chunks_size": chunks_size,
        "data_files_size_in_mb": data_file_mb, "video_files_size_in_mb": video_file_mb, "fps": schema.fps,
        "splits": {}, "data_path": layout.DATA_PATH,
        "video_path": layout.VIDEO_PATH if schema.cameras else None,
        "features": features,
        "mgdata": {"format": MGDATA_FORMAT, "spec": spec_to_dict(spec) if spec else None,
                   "hold_steps": hold_steps, "kept_only": kept_only,
                   "video_file_seconds": video_file_seconds, "episodes_per_file": episodes_per_file,
                   "scenes_per_file": scenes_per_file,
                   "attempts": None, "sha256": {}},
    }


_MARK = "\0sha256\0"


def dump_json(data: Any) -> str:
    """``data`` as indented JSON (``json.dumps(data, indent=4)``, non-ASCII kept, no NaN) plus a newline.

    ``info.json``'s checksum block (``mgdata.sha256``, one entry per dataset file) is written by a join of
    its entries instead of the (pure-Python) indenting encoder, with the same bytes, so rewriting
    ``info.json`` at every commit stays cheap as the dataset grows.
    """
    mg = data.get("mgdata") if isinstance(data, dict) else None
    sums = mg.get("sha256") if isinstance(mg, dict) else None
    if not isinstance(sums, dict) or not sums or not all(isinstance(v, str) for v in sums.values()):
        return json.dumps(data, indent=4, ensure_ascii=False, allow_nan=False) + "\n"
    text = json.dumps({**data, "mgdata": {**mg, "sha256": _MARK}}, indent=4, ensure_ascii=False,
                      allow_nan=False)
    entries = ",\n".join(f"{' ' * 12}{json.dumps(k, ensure_ascii=False)}: {json.dumps(v, ensure_ascii=False)}"
                         for k, v in sums.items())
    return text.replace(json.dumps(_MARK), "{\n" + entries + "\n" + " " * 8 + "}", 1) + "\n"


def read_info(path: Path) -> dict[str, Any]:
    """Load and check ``info.json``: a v3.0 dataset written by mgdata."""
    try:
        info = json.loads(path.read_text())
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing (not a LeRobot dataset, or not created yet)") from None
    except (OSError, ValueError) as err:
        raise DatasetError(f"{path}: unreadable JSON ({err})") from err
    if not isinstance(info, dict):
        raise DatasetError(f"{path}: expected a JSON object")
    version = info.get("codebase_version")
    if version != layout.CODEBASE_VERSION:
        raise DatasetError(f"{path}: codebase_version {version!r}; mgdata reads LeRobot "
                           f"{layout.CODEBASE_VERSION!r} datasets")
    missing = [k for k in _REQUIRED if k not in info]
    if missing:
        raise DatasetError(f"{path}: missing keys {missing}")
    mg = info.get("mgdata")
    if not isinstance(mg, dict) or mg.get("format") != MGDATA_FORMAT:
        raise DatasetError(f"{path}: no mgdata block of format {MGDATA_FORMAT} (not written by mgdata)")
    typed = {"fps": int, "total_episodes": int, "total_frames": int, "total_tasks": int, "chunks_size": int,
             "features": dict, "splits": dict, "data_path": str, "mgdata.sha256": dict,
             "mgdata.attempts": (int, type(None)), "mgdata.video_file_seconds": (int, float),
             "mgdata.episodes_per_file": (int, type(None)), "mgdata.scenes_per_file": (int, type(None))}
    for key, kind in typed.items():
        block, _, name = key.rpartition(".")
        table = mg if block else info
        if name in table and (not isinstance(table[name], kind) or isinstance(table[name], bool)):
            raise DatasetError(f"{path}: {key} = {table[name]!r} has the wrong type (corrupt info.json)")
    if info["chunks_size"] < 1 or info["fps"] < 1 or min(info["total_episodes"], info["total_frames"]) < 0:
        raise DatasetError(f"{path}: chunks_size, fps, total_episodes or total_frames out of range")
    if mg.get("scenes_per_file") is not None and mg["scenes_per_file"] < 1:
        raise DatasetError(f"{path}: mgdata.scenes_per_file = {mg['scenes_per_file']}, expected >= 1")
    return info


def schema_from_info(info: Mapping[str, Any], where: str) -> DatasetSchema:
    """The DatasetSchema a dataset was created with, read from its features."""
    feats = info["features"]
    try:
        videos = [k for k, f in feats.items() if f["dtype"] == "video"]
        shape = feats[videos[0]]["shape"] if videos else [0, 0, 3]

        def names(key: str) -> tuple[str, ...]:
            return tuple(feats[key]["names"]) if key in feats else ()

        return DatasetSchema(
            fps=int(info["fps"]), cameras=tuple(layout.camera_name(k) for k in videos),
            image_height=int(shape[0]), image_width=int(shape[1]),
            propositions=names(layout.LABELS), constraints=names(layout.DFA_STATE),
            robot_type=str(info.get("robot_type")), state_names=names(layout.STATE),
            action_names=names(layout.ACTION),
            physics_state_size=int(feats[layout.PHYSICS_STATE]["shape"][0]) if layout.PHYSICS_STATE in feats
            else 0,
            executed_action=layout.EXECUTED_ACTION in feats,
        )
    except (KeyError, TypeError, IndexError) as err:
        raise DatasetError(f"{where}: malformed features ({err})") from err


def gate_from_info(info: Mapping[str, Any], where: str) -> tuple[int | None, bool]:
    """``(hold_steps, kept_only)`` from the ``mgdata`` block (``(None, False)``: the writer got neither)."""
    mg = info["mgdata"]
    hold, kept_only = mg.get("hold_steps"), mg.get("kept_only", False)
    if hold is not None and (not isinstance(hold, int) or isinstance(hold, bool) or hold < 1):
        raise DatasetError(f"{where}: mgdata.hold_steps is {hold!r}, expected an integer >= 1 or null")
    if not isinstance(kept_only, bool):
        raise DatasetError(f"{where}: mgdata.kept_only is {kept_only!r}, expected true or false")
    return hold, kept_only


def physics_spec_from_info(info: Mapping[str, Any], where: str) -> int | None:
    """The MuJoCo state spec (``mjtState`` bits) of ``sim.physics_state`` (``None``: no such feature)."""
    feat = info["features"].get(layout.PHYSICS_STATE)
    if feat is None:
        return None
    try:
        spec = feat["info"]["mujoco_state_spec"]
    except (KeyError, TypeError) as err:
        raise DatasetError(f"{where}: feature {layout.PHYSICS_STATE!r} lacks info.mujoco_state_spec") from err
    if not isinstance(spec, int) or isinstance(spec, bool) or spec <= 0:
        raise DatasetError(f"{where}: {layout.PHYSICS_STATE} info.mujoco_state_spec is {spec!r}, expected a "
                           "positive integer (mjtState bits)")
    return spec


def video_settings_from_info(info: Mapping[str, Any], where: str) -> VideoSettings:
    for feat in info["features"].values():
        if feat.get("dtype") == "video":
            try:
                return VideoSettings.from_info(feat["info"])
            except (KeyError, TypeError, ValueError) as err:
                raise DatasetError(f"{where}: malformed video info ({err})") from err
    return VideoSettings()


# --- tasks.parquet: the task strings are the (pandas) index, as LeRobot reads them ---------------------

_PANDAS_META = {
    "index_columns": ["task"],
    "column_indexes": [{"name": None, "field_name": None, "pandas_type": "unicode", "numpy_type": "object",
                        "metadata": {"encoding": "UTF-8"}}],
    "columns": [
        {"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64",
         "metadata": None},
        {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object",
         "metadata": None},
    ],
    "creator": {"library": "pyarrow", "version": "mgdata"},
    "pandas_version": "2.2.3",
}


def write_tasks(tasks: list[str], path: Path) -> None:
    table = pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()),
                      "task": pa.array(tasks, pa.string())})
    table = table.replace_schema_metadata({"pandas": json.dumps(_PANDAS_META)})
    pq.write_table(table, path)


def read_tasks(path: Path) -> list[str]:
    """Task strings in ``task_index`` order (reads LeRobot's unnamed-index variant too)."""
    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing") from None
    except (OSError, pa.ArrowException) as err:
        raise DatasetError(f"{path}: unreadable parquet ({err})") from err
    name = "task" if "task" in table.column_names else "__index_level_0__"
    if name not in table.column_names or "task_index" not in table.column_names:
        raise DatasetError(f"{path}: expected columns 'task' and 'task_index', found {table.column_names}")
    index = table.column("task_index").to_pylist()
    if index != list(range(len(index))):
        raise DatasetError(f"{path}: task_index is not 0..{len(index) - 1} in order")
    return [str(t) for t in table.column(name).to_pylist()]
