"""The grasp database: object-local TCP poses for each object model, stored as JSON under ``grasps/``.

Layout: one file per object category, ``grasps/<category>.json``, whose ``objects`` table is keyed by the
asset-library name ``category/model``. Each grasp is the pose of the Panda's ``TCP`` site in the object's own
frame (origin and axes as the asset library documents them):

* ``pos``: position in metres; ``quat_wxyz``: orientation as a unit quaternion, scalar first.
* The gripper approaches along its **+Z** axis (palm towards fingertips) and the fingers close along its
  **±Y** axis (the Panda finger joints slide along the hand's Y axis).
* ``frame`` (optional): the body of the object the pose is expressed in, by its local name (``"drawer"``
  for a cabinet's drawer handle, so the grasp moves with the drawer); absent or ``""`` means the object's
  root frame.
* At run time the world TCP target is ``T_world_frame @ T_frame_grasp``: :meth:`Grasp.world_matrix` reads
  ``T_world_frame`` from a live ``MjData``.

``grasps/schema.json`` is the same format as a JSON Schema for editors and external tools; this module is the
validator the toolkit uses (one :class:`GraspDBError` naming the file, the key path and what was expected).

Example::

    db = GraspDB.load_dir(grasps_dir())
    for g in db.grasps("jar/hinged_00", status="valid"):
        print(g.id, g.approach, g.matrix())
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mgdata.atomic import write_text_atomic
from mgdata.errors import GraspDBError

SCHEMA_VERSION = 1
APPROACH_HINTS: tuple[str, ...] = ("top_down", "side", "bottom_up")
SOURCES: tuple[str, ...] = ("generated", "annotated")
STATUSES: tuple[str, ...] = ("unvalidated", "valid", "invalid")
CONVENTION = (
    "pose of the Panda TCP site in the object's local frame; pos in metres, quat_wxyz scalar-first unit "
    "quaternion; approach = gripper +Z, fingers close along gripper ±Y; world target = T_world_object @ pose"
)
CONVENTION_FRAMES = CONVENTION + (
    "; a grasp with 'frame' is in that body of the object instead (world target = T_world_frame @ pose)"
)


@dataclass(frozen=True)
class Grasp:
    """One grasp of one object model.

    Attributes:
        id: identifier unique within the object (``"side_03"``).
        pos: TCP position in the object frame (m).
        quat: TCP orientation in the object frame, unit quaternion (w, x, y, z).
        approach: hint ``top_down`` / ``side`` / ``bottom_up`` (direction of the gripper's +Z).
        source: ``generated`` (from geometry) or ``annotated`` (by a person).
        status: ``unvalidated``, ``valid`` or ``invalid`` (set by ``mgdata grasps validate``).
        detail: what the last validation measured or why it failed.
        frame: local name of the object body the pose is in (``"drawer"``); ``""`` is the object's root.
    """

    id: str
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    approach: str
    source: str
    status: str = "unvalidated"
    detail: str = ""
    frame: str = ""

    def matrix(self) -> np.ndarray:
        """The 4×4 homogeneous transform object → TCP."""
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, np.asarray(self.quat, dtype=float))
        out = np.eye(4)
        out[:3, :3] = rot.reshape(3, 3)
        out[:3, 3] = self.pos
        return out

    def body_name(self, instance: str) -> str:
        """Scene body name of the grasp's frame for object instance ``instance`` (``"cab/drawer"``)."""
        return f"{instance}/{self.frame}" if self.frame else instance

    def world_matrix(self, model: mujoco.MjModel, data: mujoco.MjData, instance: str) -> np.ndarray:
        """The 4×4 world TCP target of this grasp on object instance ``instance`` in a live scene
        (``data`` after ``mj_forward``): ``T_world_frame @ matrix()``. A drawer-handle grasp follows the
        drawer wherever its joint is."""
        try:
            body = model.body(self.body_name(instance)).id
        except KeyError:
            name = self.body_name(instance)
            raise GraspDBError(f"grasp {self.id!r}: no body {name!r} in the scene") from None
        frame = np.eye(4)
        frame[:3, :3] = data.xmat[body].reshape(3, 3)
        frame[:3, 3] = data.xpos[body]
        return frame @ self.matrix()

    def with_status(self, status: str, detail: str = "") -> Grasp:
        if status not in STATUSES:
            raise GraspDBError(f"grasp {self.id!r}: status {status!r} is not one of {', '.join(STATUSES)}")
        return replace(self, status=status, detail=detail)


@dataclass(frozen=True)
class GraspDB:
    """All grasps, keyed by object model (``category/model``); keys and grasp lists keep their file order."""

    objects: Mapping[str, tuple[Grasp, ...]]

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(self.objects)

    def grasps(self, key: str, status: str | None = None) -> tuple[Grasp, ...]:
        """The grasps of one model, optionally only those with a given validation status."""
        if key not in self.objects:
            known = ", ".join(sorted(self.objects)) or "none"
            raise GraspDBError(f"no grasps for object model {key!r} (models with grasps: {known})")
        found = self.objects[key]
        return found if status is None else tuple(g for g in found if g.status == status)

    def with_object(self, key: str, grasps: Iterable[Grasp]) -> GraspDB:
        """A copy with the grasps of ``key`` replaced (or added)."""
        _check_key(key, "with_object")
        grasps = tuple(grasps)
        _check_unique(key, grasps, "with_object")
        objects = dict(self.objects)
        objects[key] = grasps
        return GraspDB(objects)

    def without_object(self, key: str) -> GraspDB:
        """A copy without ``key``'s grasps."""
        return GraspDB({k: v for k, v in self.objects.items() if k != key})

    @classmethod
    def load(cls, paths: Iterable[Path]) -> GraspDB:
        """Load and validate several category files; a model may appear in only one of them."""
        objects: dict[str, tuple[Grasp, ...]] = {}
        origin: dict[str, Path] = {}
        for path in paths:
            for key, grasps in _load_file(Path(path)).items():
                if key in objects:
                    raise GraspDBError(f"{path}: object {key!r} is also defined in {origin[key]}")
                objects[key], origin[key] = grasps, Path(path)
        return cls(objects)

    @classmethod
    def load_dir(cls, directory: Path) -> GraspDB:
        """Load every ``*.json`` in ``directory`` except ``schema.json`` (an empty DB if there is none)."""
        directory = Path(directory)
        if not directory.is_dir():
            return cls({})
        return cls.load(sorted(p for p in directory.glob("*.json") if p.name != "schema.json"))

    def write_dir(self, directory: Path, categories: Iterable[str] | None = None) -> list[Path]:
        """Write one file per category atomically (only ``categories``, if given: a run that changed one
        category leaves the others' files alone; a given category left without objects loses its file);
        returns the paths written."""
        directory = Path(directory)
        wanted = None if categories is None else set(categories)
        by_category: dict[str, dict[str, tuple[Grasp, ...]]] = {}
        for key in sorted(self.objects):
            category = key.split("/", 1)[0]
            if wanted is None or category in wanted:
                by_category.setdefault(category, {})[key] = self.objects[key]
        written = []
        for category, objects in by_category.items():
            path = directory / f"{category}.json"
            write_file(path, objects)
            written.append(path)
        for category in (wanted or set()) - set(by_category):
            (directory / f"{category}.json").unlink(missing_ok=True)
        return written


def approach_hint(quat: Iterable[float]) -> str:
    """The approach hint of a TCP orientation (w, x, y, z) in the object frame, from the angle between the
    gripper's +Z and straight down: up to 60° ``top_down``, from 120° ``bottom_up``, otherwise ``side``."""
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(tuple(quat), dtype=float))
    down = -float(rot[8])  # (+Z of the gripper) · (0, 0, −1)
    angle = math.degrees(math.acos(min(1.0, max(-1.0, down))))
    return "top_down" if angle <= 60.0 else "bottom_up" if angle >= 120.0 else "side"


def write_file(path: Path, objects: Mapping[str, Iterable[Grasp]]) -> None:
    """Write one category file atomically: readers see the old file or the new one, never a partial one."""
    objects = {key: tuple(objects[key]) for key in objects}
    framed = any(g.frame for gs in objects.values() for g in gs)
    doc = {
        "schema_version": SCHEMA_VERSION,
        "convention": CONVENTION_FRAMES if framed else CONVENTION,
        "objects": {key: {"grasps": [_grasp_to_json(g) for g in objects[key]]} for key in sorted(objects)},
    }
    write_text_atomic(Path(path), json.dumps(doc, indent=2) + "\n")


def _grasp_to_json(g: Grasp) -> dict[str, Any]:
    out: dict[str, Any] = {
        "id": g.id,
        "pos": [round(v, 6) for v in g.pos],
        "quat_wxyz": [round(v, 8) for v in g.quat],
        "approach": g.approach,
        "source": g.source,
    }
    if g.frame:  # written only when set: files without frames stay as they were
        out["frame"] = g.frame
    out["validation"] = {"status": g.status, "detail": g.detail}
    return out


def _load_file(path: Path) -> dict[str, tuple[Grasp, ...]]:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise GraspDBError(f"{path}: grasp file not found") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise GraspDBError(f"{path}: not valid JSON ({err})") from None
    if not isinstance(doc, dict):
        raise GraspDBError(f"{path}: expected a JSON object at the top level")
    if doc.get("schema_version") != SCHEMA_VERSION:
        raise GraspDBError(
            f"{path}: schema_version {doc.get('schema_version')!r} is not supported "
            f"(expected {SCHEMA_VERSION})"
        )
    objects = doc.get("objects")
    if not isinstance(objects, dict):
        raise GraspDBError(f"{path}: 'objects' must be an object keyed by 'category/model'")
    category = path.stem
    out: dict[str, tuple[Grasp, ...]] = {}
    for key, entry in objects.items():
        where = f"{path}: objects[{key!r}]"
        _check_key(key, where)
        if key.split("/", 1)[0] != category:
            raise GraspDBError(f"{where}: category {key.split('/', 1)[0]!r} does not match file {path.name}")
        if not isinstance(entry, dict) or not isinstance(entry.get("grasps"), list):
            raise GraspDBError(f"{where}: expected an object with a 'grasps' list")
        grasps = tuple(_parse_grasp(g, f"{where}.grasps[{i}]") for i, g in enumerate(entry["grasps"]))
        _check_unique(key, grasps, where)
        out[key] = grasps
    return out


def _parse_grasp(raw: Any, where: str) -> Grasp:
    if not isinstance(raw, dict):
        raise GraspDBError(f"{where}: expected an object")
    for field in ("id", "pos", "quat_wxyz", "approach", "source"):
        if field not in raw:
            raise GraspDBError(f"{where}: missing key {field!r}")
    gid = raw["id"]
    if not isinstance(gid, str) or not gid:
        raise GraspDBError(f"{where}.id: expected a non-empty string, got {gid!r}")
    pos = _numbers(raw["pos"], 3, f"{where}.pos")
    quat = _numbers(raw["quat_wxyz"], 4, f"{where}.quat_wxyz")
    norm = math.sqrt(sum(v * v for v in quat))
    if abs(norm - 1.0) > 1e-3:
        raise GraspDBError(f"{where}.quat_wxyz: expected a unit quaternion (w, x, y, z), norm is {norm:.4f}")
    quat = tuple(v / norm for v in quat)
    approach, source = raw["approach"], raw["source"]
    if approach not in APPROACH_HINTS:
        raise GraspDBError(f"{where}.approach: {approach!r} is not one of {', '.join(APPROACH_HINTS)}")
    if source not in SOURCES:
        raise GraspDBError(f"{where}.source: {source!r} is not one of {', '.join(SOURCES)}")
    validation = raw.get("validation", {"status": "unvalidated", "detail": ""})
    if not isinstance(validation, dict) or validation.get("status") not in STATUSES:
        raise GraspDBError(
            f"{where}.validation: expected {{'status': one of {', '.join(STATUSES)}, 'detail': str}}"
        )
    detail = validation.get("detail", "")
    if not isinstance(detail, str):
        raise GraspDBError(f"{where}.validation.detail: expected a string, got {detail!r}")
    frame = raw.get("frame", "")
    if not isinstance(frame, str) or "/" in frame:
        raise GraspDBError(f"{where}.frame: expected a body's local name without '/', got {frame!r}")
    return Grasp(gid, pos, quat, approach, source, validation["status"], detail,  # type: ignore[arg-type]
                 frame)


def _numbers(raw: Any, n: int, where: str) -> tuple[float, ...]:
    ok = isinstance(raw, list) and len(raw) == n and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in raw
    )
    if not ok:
        raise GraspDBError(f"{where}: expected a list of {n} finite numbers, got {raw!r}")
    return tuple(float(v) for v in raw)


def _check_key(key: str, where: str) -> None:
    parts = key.split("/") if isinstance(key, str) else []
    if len(parts) != 2 or not all(parts):
        raise GraspDBError(f"{where}: object key {key!r} must have the form 'category/model'")


def _check_unique(key: str, grasps: tuple[Grasp, ...], where: str) -> None:
    seen: set[str] = set()
    for g in grasps:
        if g.id in seen:
            raise GraspDBError(f"{where}: grasp id {g.id!r} appears twice for {key!r}")
        seen.add(g.id)
