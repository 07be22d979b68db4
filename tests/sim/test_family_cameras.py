"""A family recipe's ``[cameras]`` table frames its third-person views: the compiled cameras look where the
table says, the physics is untouched, bad tables are one error, and the shipped framings keep every key
object and the goal inside every third-person view (projected here from raw MuJoCo data), with the jar and
clutter families' key objects ≥ 1.5 % of the frame in two views and the other families' small key objects
larger than through ``recipes/sim.toml``'s views (segmentation renders)."""

from __future__ import annotations

import copy
import dataclasses
import re

import mujoco
import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.errors import RecipeError
from mgdata.sim.cameras import THIRD_PERSON, WRIST
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import family_recipes, load_recipe
from tests.helpers.repo import REPO

KEYS = {"jar": ("jar",), "clutter_dry": ("target",), "clutter_liquid": ("container",),
        "dusty": ("dest", "sponge", "source"), "cabinet": ("cabinet", "target"), "lid": ("container", "lid"),
        "stack": ("target", "stack")}
"""The objects each family's task is about (the success predicates' subjects and what is handled); a role
with several instances (``stack_0`` … ``stack_2``) counts as one object."""
LARGE = ("jar", "clutter_dry", "clutter_liquid")
"""Families whose key objects fill ≥ 1.5 % of two third-person views (docs/render.md, "Framing")."""
SIZE = 256


def _top_bodies(model: mujoco.MjModel, name: str) -> list[int]:
    """The bodies of instance ``name`` (or of every instance ``name_<i>``) and everything under them."""
    roots = {b for b in range(1, model.nbody) if model.body_parentid[b] == 0
             and re.fullmatch(rf"{name}(_\d+)?", model.body(b).name)}
    out = []
    for b in range(model.nbody):
        a = b
        while a and a not in roots:
            a = int(model.body_parentid[a])
        if a in roots:
            out.append(b)
    return out


def _points(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    """World corners of the bounding boxes of the instance's drawn geoms."""
    bodies = _top_bodies(model, name)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    pts = [data.geom_xpos[g] + (model.geom_aabb[g, :3] + signs * model.geom_aabb[g, 3:])
           @ data.geom_xmat[g].reshape(3, 3).T
           for g in range(model.ngeom) if model.geom_bodyid[g] in bodies and model.geom_group[g] < 3]
    return np.concatenate(pts)


def _pixels(model: mujoco.MjModel, data: mujoco.MjData, camera: str, pts: np.ndarray) -> np.ndarray:
    """Pixel coordinates of world points through the camera's pose and field of view (MuJoCo's pinhole)."""
    cam = model.camera(camera).id
    local = (pts - data.cam_xpos[cam]) @ data.cam_xmat[cam].reshape(3, 3)
    depth = -local[:, 2]
    assert (depth > 0).all(), f"{camera}: points behind the camera"
    f = 0.5 * SIZE / np.tan(np.radians(model.cam_fovy[cam]) / 2.0)
    return np.column_stack([0.5 * SIZE + f * local[:, 0] / depth, 0.5 * SIZE - f * local[:, 1] / depth])


def test_the_recipe_table_places_the_cameras_and_leaves_physics_alone() -> None:
    recipe = load_family_recipe("jar")
    assert set(recipe.cameras) >= {"fovy", "look_at", *THIRD_PERSON}
    framed = draw_task(recipe, 0, 0)
    plain = build_scene(dataclasses.replace(framed, cameras={}))
    scene = build_scene(framed)
    m, d = scene.model, scene.data
    look_at = np.asarray(recipe.cameras["look_at"])  # the base stands at the origin, unturned
    for name in THIRD_PERSON:
        cam = m.camera(name).id
        assert np.allclose(d.cam_xpos[cam], recipe.cameras[name], atol=1e-9)
        assert m.cam_fovy[cam] == recipe.cameras["fovy"]
        axis = -d.cam_xmat[cam].reshape(3, 3)[:, 2]  # MuJoCo cameras look along their −Z
        to = look_at - d.cam_xpos[cam]
        assert np.allclose(axis, to / np.linalg.norm(to), atol=1e-9)
        assert not np.allclose(d.cam_xpos[cam], plain.data.cam_xpos[plain.model.camera(name).id])
    w, pw = m.camera(WRIST).id, plain.model.camera(WRIST).id
    assert np.array_equal(m.cam_pos[w], plain.model.cam_pos[pw]) and m.cam_fovy[w] == plain.model.cam_fovy[pw]
    for s in (scene, plain):
        s.reset()
        s.data.ctrl[:] = 0.3 * np.sin(np.arange(s.model.nu))
        for _ in range(200):
            mujoco.mj_step(s.model, s.data)
    assert np.array_equal(scene.data.qpos, plain.data.qpos)
    assert np.array_equal(scene.data.qvel, plain.data.qvel)


@pytest.mark.parametrize(("table", "message"), [
    ("wrist_fovy = 60.0", r"unknown key\(s\) \['wrist_fovy'\]; a family may set"),
    ("image_size = 128", r"unknown key\(s\) \['image_size'\]"),
    ("front = [1.0, 0.0]", r"\[cameras\] front = \[1.0, 0.0\]: expected a list of 3 numbers"),
    ("fovy = 200.0", r"\[cameras\] fovy = 200.0: expected degrees in \(0, 180\)"),
    ("left = [0.45, 0.0, 1.5]\nlook_at = [0.45, 0.0, 0.2]", r"\[cameras\] left = .*straight above or below"),
])
def test_a_bad_table_is_one_error_naming_the_key(tmp_path, table: str, message: str) -> None:  # type: ignore[no-untyped-def]
    text = (REPO / "recipes" / "jar.toml").read_text()
    start = text.index("\n[cameras]\n") + 1
    end = text.index("\n\n", start)
    (tmp_path / "specs").symlink_to(REPO / "recipes" / "specs")
    path = tmp_path / "jar.toml"
    path.write_text(text[:start] + "[cameras]\n" + table + text[end:])
    with pytest.raises(RecipeError, match=message) as err:
        load_recipe(path)
    assert str(path) in str(err.value)


def _shares(model: mujoco.MjModel, data: mujoco.MjData, names: tuple[str, ...]) -> dict[str, list[float]]:
    """Each instance's share of each third-person frame (segmentation renders; everything drawn but the
    goal sphere, which is transparent in the pictures and opaque in a segmentation)."""
    out: dict[str, list[float]] = {n: [] for n in names}
    model = copy.copy(model)
    goal = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "goal")
    if goal >= 0:
        model.geom_group[goal] = 3  # a group MuJoCo does not draw by default
    r = mujoco.Renderer(model, SIZE, SIZE)
    try:
        r.enable_segmentation_rendering()
        for camera in THIRD_PERSON:
            r.update_scene(data, camera=camera)
            seg = r.render()
            ids = np.where(seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM, seg[..., 0], -1)
            for name in names:
                geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] in _top_bodies(model, name)]
                out[name].append(float(np.isin(ids, geoms).mean()))
    finally:
        r.close()
    return out


@pytest.mark.parametrize("family", sorted(KEYS))
def test_the_shipped_framing_holds_the_work(family: str) -> None:
    assert family in family_recipes()
    recipe = load_family_recipe(family)
    assert recipe.cameras, f"{family}: no [cameras] table (sim.toml's views frame the whole table)"
    task = base_task(recipe, 0)  # as generation draws it (the gate may reject draw 0)
    scene, plain = build_scene(task), build_scene(dataclasses.replace(task, cameras={}))
    for s in (scene, plain):
        s.reset()
    m, d = scene.model, scene.data
    things = {k: _points(m, d, k) for k in KEYS[family]}
    if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "goal") >= 0:
        g = m.geom("goal").id
        things["goal"] = d.geom_xpos[g] + m.geom_size[g, 0] * np.concatenate([np.eye(3), -np.eye(3)])
    for camera in THIRD_PERSON:
        for name, pts in things.items():
            px = _pixels(m, d, camera, pts)
            assert ((px >= 0) & (px <= SIZE)).all(), f"{family}: {name} leaves the {camera} view"
    framed, before = _shares(m, d, KEYS[family]), _shares(plain.model, plain.data, KEYS[family])
    for name in KEYS[family]:  # the second-best view, as the rule counts views: small objects grow by a
        new, old = sorted(framed[name])[-2], sorted(before[name])[-2]  # fifth or more, large ones stay large
        assert new >= min(1.2 * old, 0.05), f"{family}: {name} second-best {new:.2%}, sim.toml's {old:.2%}"
        if family in LARGE:
            assert new >= 0.015, f"{family}: {name} covers {framed[name]} of the four views"


def test_a_scenario_keeps_the_family_framing(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``scenario.json`` records the framing and a restored scenario's task carries it, so a rebuild from the
    metadata places the cameras where the stored scene has them."""
    from mgdata.evaluate.restore import restore_scenario
    from mgdata.scenarios.store import build_scenario, scenario_dir

    recipe = load_family_recipe("jar")
    build_scenario(recipe, 0, "base", tmp_path)
    restored = restore_scenario(scenario_dir(tmp_path, "jar", 0, "base"))
    task = restored.scene.task
    assert dict(task.cameras) == dict(recipe.cameras)
    rebuilt = build_scene(task)
    for name in THIRD_PERSON:
        stored = restored.scene.model.camera(name).id
        assert np.allclose(restored.scene.model.cam_pos[stored], rebuilt.model.cam_pos[stored], atol=1e-12)
        assert np.allclose(restored.scene.model.cam_pos[stored], recipe.cameras[name], atol=1e-9)
