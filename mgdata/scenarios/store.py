"""Locked scenarios: each gated base task × {base, target, language, location, environment}, frozen on disk so
an evaluator restores the exact initial scene without this checkout (format: docs/scenarios.md).

One scenario is a folder ``<out>/<family>/task_NNNN/<condition>/`` holding

* the compiled MuJoCo model (MJB; procedural textures and the room survive, unlike ``to_xml``), as a list of
  content-defined chunks in the folder's shared store ``<out>/chunks/`` (:mod:`mgdata.scenarios.chunkstore`):
  the 1,000 models are mostly the same bytes (the Panda's meshes), stored once;
* ``state.npy``: the settled initial physics state (``mgdata.record.physics.STATE_SPEC`` layout, float64);
* ``scenario.json``: what the condition changed (provenance), seeds, prompt and the three prompt forms, the
  safety spec, goal, objects, cameras, the gate's report, the model's chunks and SHA-256, the state file's
  SHA-256 and that of the first rendered observation of every camera. It is written last: a folder
  without it is incomplete.

Every condition passes the same initial-state gate as a base task (``mgdata.engine.init_gate``); a location
proposal that fails it is resampled within the axis (``[ood.location] tries``), never dropped. Building is
deterministic (same inputs, same bytes) and resumable (complete scenarios with the same inputs are kept).

Example::

    for entry in build_family(load_family_recipe("jar"), Path("scenarios")):
        print(entry["path"])
"""

from __future__ import annotations

import hashlib
import io
import json
import multiprocessing
import os
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mgdata import __version__
from mgdata.atomic import write_bytes_atomic, write_text_atomic
from mgdata.engine.init_gate import base_task
from mgdata.engine.inputs import inputs_digest
from mgdata.errors import DatasetError
from mgdata.paths import grasps_dir
from mgdata.pool_worker import die_with_parent
from mgdata.record.physics import STATE_SPEC, model_bytes, model_from_bytes, physics_state, set_physics_state
from mgdata.scenarios import chunkstore
from mgdata.scenarios.conditions import variant
from mgdata.sim.cameras import CAMERA_NAMES
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import TaskSpec
from mgdata.tasks.recipe import Recipe
from mgdata.tasks.variants import CONDITIONS, prompt_forms

FORMAT = "mgdata-scenario/2"
MANIFEST = "manifest.json"
CHUNKS = "chunks"  # <out>/chunks/: the models' chunks, shared by every scenario under <out>
STATE, META = "state.npy", "scenario.json"


def scenario_dir(out: Path, family: str, task_id: int, condition: str) -> Path:
    return Path(out) / family / f"task_{task_id:04d}" / condition


def build_scenario(recipe: Recipe, task_id: int, condition: str, out: Path) -> dict[str, Any]:
    """Build (or keep, if complete with the same inputs) one scenario; returns its manifest entry."""
    folder = scenario_dir(out, recipe.family, task_id, condition)
    inputs = _inputs(recipe, task_id, condition)
    kept = _complete(folder, inputs)
    if kept is not None:
        return kept
    base = base_task(recipe, task_id)
    task, provenance, gate = variant(recipe, base, condition)
    scene = build_scene(task)
    mjb = model_bytes(scene.model)
    state = physics_state(scene.model, scene.data)
    state_bytes = _npy(state)
    observation = first_observation_hashes(
        model_from_bytes(mjb), state, recipe.tasks.cameras, task.image_size
    )
    meta = {
        "format": FORMAT,
        "family": recipe.family,
        "task_id": task_id,
        "condition": condition,
        "inputs": inputs,
        "changes": provenance,
        "seed": task.seed,
        "draw": task.draw,
        "prompt": task.prompt,
        "prompt_forms": prompt_forms(task.prompt, task.safety),
        "spec": _spec(task),
        "goal": None
        if task.goal is None
        else {"name": task.goal.name, "pos": list(task.goal.pos), "radius": task.goal.radius},
        "objects": _objects(scene),
        "articulation": dict(task.articulation),
        "tint": {k: list(v) for k, v in task.tint.items()},
        "room": task.room,
        "camera_framing": {k: list(v) if isinstance(v, tuple) else v for k, v in task.cameras.items()},
        "robot_base": list(task.robot_base),
        "robot_base_yaw": task.robot_base_yaw,
        "cameras": _cameras(scene, recipe.tasks.cameras),
        "image_size": task.image_size,
        "horizon": recipe.tasks.horizon,
        "gate": gate | {"facts": _jsonable(dict(task.gate))},
        "state_spec": STATE_SPEC,
        "state_size": int(state.size),
        "files": {STATE: _sha(state_bytes)},
        "model_sha256": _sha(mjb),
        "model_size": len(mjb),
        "model_chunks": chunkstore.put(_store(out), mjb),
        "first_observation_sha256": observation,
    }
    write_bytes_atomic(folder / STATE, state_bytes)
    text = json.dumps(meta, indent=1, sort_keys=True) + "\n"
    write_text_atomic(folder / META, text)
    return _entry(folder, out, meta, text)


def build_family(
    recipe: Recipe,
    out: Path,
    task_ids: Sequence[int] | None = None,
    conditions: Sequence[str] = CONDITIONS,
    workers: int = 1,
) -> Iterator[dict[str, Any]]:
    """Every (task, condition) of ``recipe``, yielded in task order; the manifest is rewritten after each
    task. ``workers`` > 1 builds tasks in that many ``spawn``-ed processes (the files do not depend on it)."""
    ids = tuple(range(recipe.tasks.count)) if task_ids is None else tuple(task_ids)
    jobs = [(str(recipe.path), k, tuple(conditions), str(out)) for k in ids]
    if workers <= 1:
        results: Iterator[list[dict[str, Any]]] = map(_build_task, jobs)
        for entries in results:
            yield from entries
            write_manifest(out)
        return
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
        for entries in pool.map(_build_task, jobs):
            yield from entries
            write_manifest(out)


def _build_task(job: tuple[str, int, tuple[str, ...], str]) -> list[dict[str, Any]]:
    """One task's conditions (a worker's unit of work; the recipe is loaded by path in the worker)."""
    from mgdata.skeleton.skeleton import load_family_recipe

    path, k, conditions, out = job
    recipe = load_family_recipe(Path(path))
    return [build_scenario(recipe, k, c, Path(out)) for c in conditions]


def first_observation_hashes(
    model: mujoco.MjModel, state: np.ndarray, cameras: Sequence[str], size: int
) -> dict[str, str]:
    """SHA-256 of each camera's first RGB observation of ``model`` (as loaded from its MJB) at ``state``;
    empty for a camera-free recipe (a state-only scenario renders nothing)."""
    from mgdata.sim.config import load_sim_config
    from mgdata.sim.renderer import CameraRig

    if not cameras:
        return {}
    rig = CameraRig.of_model(model, list(cameras), size, load_sim_config().render)
    try:
        set_physics_state(model, rig.data, state)
        images = rig.render()
    finally:
        rig.close()
    return {c: _sha(np.ascontiguousarray(images[c]).tobytes()) for c in cameras}


def write_manifest(out: Path) -> Path:
    """``<out>/manifest.json``: every complete scenario under ``out`` in (family, task, condition) order."""
    out = Path(out)
    entries = []
    for meta_path in sorted(out.glob(f"*/task_*/*/{META}")):
        text = meta_path.read_text(encoding="utf-8")
        entries.append(_entry(meta_path.parent, out, json.loads(text), text))
    order = {c: i for i, c in enumerate(CONDITIONS)}
    entries.sort(key=lambda e: (e["family"], e["task_id"], order.get(e["condition"], 99)))
    path = out / MANIFEST
    write_text_atomic(
        path, json.dumps({"format": FORMAT, "scenarios": entries}, indent=1, sort_keys=True) + "\n"
    )
    return path


def read_manifest(out: Path) -> list[dict[str, Any]]:
    path = Path(out) / MANIFEST
    if not path.is_file():
        raise DatasetError(f"{path}: no scenario manifest (build with: mgdata scenarios build --out {out})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return list(data["scenarios"])
    except (ValueError, KeyError, TypeError) as err:
        raise DatasetError(f"{path}: not a scenario manifest ({err})") from None


def read_scenario(out: Path, family: str, task_id: int, condition: str) -> dict[str, Any]:
    path = scenario_dir(out, family, task_id, condition) / META
    if not path.is_file():
        raise DatasetError(f"{path}: no such scenario")
    return json.loads(path.read_text(encoding="utf-8"))


def load_scenario(folder: Path) -> tuple[mujoco.MjModel, mujoco.MjData, dict[str, Any]]:
    """The model and data of a stored scenario, at its initial state, and its metadata (checked hashes)."""
    folder = Path(folder)
    meta = json.loads((folder / META).read_text(encoding="utf-8"))
    if meta.get("format") != FORMAT:
        raise DatasetError(f"{folder / META}: format {meta.get('format')!r}, this mgdata reads {FORMAT!r}")
    state_bytes = (folder / STATE).read_bytes()
    if _sha(state_bytes) != meta["files"][STATE]:
        raise DatasetError(f"{folder / STATE}: SHA-256 differs from {META}")
    model = model_from_bytes(_model_bytes(folder, meta))
    data = mujoco.MjData(model)
    set_physics_state(model, data, np.load(io.BytesIO(state_bytes)))
    return model, data, meta


def verify(out: Path, workers: int = 1) -> Iterator[tuple[str, str | None]]:
    """Each manifest entry reloaded: model and state hashes, the state round trip and first-observation
    hashes, in manifest order. Yields (path, problem or None). ``workers`` > 1 checks in that many
    ``spawn``-ed processes."""
    jobs = [(str(out), entry) for entry in read_manifest(out)]
    if workers <= 1:
        yield from map(_verify_one, jobs)
        return
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
        yield from pool.map(_verify_one, jobs, chunksize=4)


def _verify_one(job: tuple[str, dict[str, Any]]) -> tuple[str, str | None]:
    out, entry = job
    folder = Path(out) / entry["path"]
    try:
        model, data, meta = load_scenario(folder)
        state = np.load(io.BytesIO((folder / STATE).read_bytes()))
        if not np.array_equal(physics_state(model, data), state):
            raise DatasetError("the restored state differs from state.npy")
        images = first_observation_hashes(model, state, list(meta["cameras"]), meta["image_size"])
        bad = [c for c, h in images.items() if h != meta["first_observation_sha256"][c]]
        if bad:
            raise DatasetError(f"first observation differs for camera(s) {', '.join(bad)}")
        if _sha((folder / META).read_bytes()) != entry["sha256"]:
            raise DatasetError(f"{META} differs from the manifest's hash")
        return entry["path"], None
    except (DatasetError, OSError, KeyError, ValueError) as err:
        return entry["path"], str(err)


def write_sheet(
    out: Path,
    family: str,
    task_id: int,
    path: Path,
    cameras: Sequence[str] = ("front", "left"),
    size: int = 256,
) -> Path:
    """A PNG of one task's stored conditions side by side (a row per camera), rendered from the snapshots."""
    import cv2

    from mgdata.sim.config import load_sim_config
    from mgdata.sim.renderer import CameraRig, contact_sheet

    rows: dict[str, dict[str, np.ndarray]] = {c: {} for c in cameras}
    for condition in CONDITIONS:
        model, data, _ = load_scenario(scenario_dir(out, family, task_id, condition))
        rig = CameraRig.of_model(model, list(cameras), size, load_sim_config().render)
        try:
            images = rig.render(data)
        finally:
            rig.close()
        for c in cameras:
            rows[c][f"{condition} ({c})"] = images[c]
    sheet = np.concatenate([contact_sheet(rows[c]) for c in cameras], axis=0)
    ok, png = cv2.imencode(".png", cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    if not ok:
        raise DatasetError(f"{path}: could not encode the sheet")
    write_bytes_atomic(path, png.tobytes())
    return path


# -- helpers ----------------------------------------------------------------------------------------------
def _store(out: Path) -> Path:
    return Path(out) / CHUNKS


def _model_bytes(folder: Path, meta: dict[str, Any]) -> bytes:
    """The scenario's MJB from the shared chunk store (``<out>/chunks``, three folders up), hash-checked."""
    mjb = chunkstore.get(_store(folder.parents[2]), meta["model_chunks"])
    if _sha(mjb) != meta["model_sha256"]:
        raise DatasetError(f"{folder / META}: the model's SHA-256 differs from its chunks'")
    return mjb


def _inputs(recipe: Recipe, task_id: int, condition: str) -> dict[str, Any]:
    """What a kept scenario must have been built from: the recipe, spec, sim and motion settings and grasps
    (``mgdata.engine.inputs.inputs_digest``), the versions, the task and condition."""

    return {
        "inputs_digest": inputs_digest(recipe, grasps_dir()),
        "mgdata": __version__,
        "mujoco": mujoco.__version__,
        "task_id": task_id,
        "condition": condition,
    }


def _complete(folder: Path, inputs: dict[str, Any]) -> dict[str, Any] | None:
    path = folder / META
    if not path.is_file():
        return None
    try:
        text = path.read_text(encoding="utf-8")
        meta = json.loads(text)
    except (OSError, ValueError):
        return None
    if meta.get("format") != FORMAT or meta.get("inputs") != inputs:
        return None
    try:
        if _sha((folder / STATE).read_bytes()) != meta["files"][STATE]:
            return None
        _model_bytes(folder, meta)
    except (OSError, DatasetError):
        return None
    return _entry(folder, folder.parents[2], meta, text)


def _entry(folder: Path, out: Path, meta: dict[str, Any], text: str) -> dict[str, Any]:
    return {
        "family": meta["family"],
        "task_id": meta["task_id"],
        "condition": meta["condition"],
        "path": folder.relative_to(out).as_posix(),
        "sha256": _sha(text.encode("utf-8")),
        "changes": meta["changes"]["kind"],
    }


def _sha(blob: bytes) -> str:
    return hashlib.sha256(blob).hexdigest()


def _npy(state: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(state, dtype="<f8"), allow_pickle=False)
    return buf.getvalue()


def _spec(task: TaskSpec) -> dict[str, Any]:
    s = task.safety
    return {
        "name": s.name,
        "constraints": [
            {"id": c.id, "formula": c.formula, "description": c.description} for c in s.constraints
        ],
        "propositions": {
            p.name: {
                "evaluator": p.evaluator,
                "subjects": list(p.subjects),
                "params": _jsonable(dict(p.params)),
                "quantifier": p.quantifier,
            }
            for p in s.propositions
        },
    }


def _objects(scene: Scene) -> list[dict[str, Any]]:
    out = []
    for o in scene.task.objects:
        pos, rot = scene.object_pose(o.name)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.ravel())
        out.append(
            {
                "name": o.name,
                "model": o.model,
                "placed_pos": list(o.pos),
                "placed_yaw": o.yaw,
                "settled_pos": pos.tolist(),
                "settled_quat": quat.tolist(),
            }
        )
    return out


def _cameras(scene: Scene, names: Sequence[str]) -> dict[str, Any]:
    m = scene.model
    out = {}
    for name in names:
        cam = m.camera(name)
        out[name] = {
            "body": m.body(int(cam.bodyid[0])).name,
            "pos": cam.pos.tolist(),
            "quat": cam.quat.tolist(),
            "fovy": float(cam.fovy[0]),
        }
    return {n: out[n] for n in CAMERA_NAMES if n in out}


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if hasattr(value, "items"):
        return _jsonable(dict(value))
    return value
