"""``mgdata objects import`` end to end on a textured box the test writes itself (OBJ + MTL + PNG): the
entry and its files, the texture bound and seen in a rendered scene (raw MuJoCo), grasps generated and
validated into the root's grasp DB, a clutter_dry recipe copy drawing the object, kept demos that
``mgdata validate`` passes, and the same file giving the same bytes."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)
from tests.helpers.textured import CYAN, MAGENTA, checker, textured_box

NAME = "block/scanned_00"


def mgdata_run(root: Path, cache: Path, *args: str | Path) -> subprocess.CompletedProcess:
    """``mgdata --root ROOT ARGS`` as a user runs it (its own process, a cache of the test's own)."""
    env = {**{k: v for k, v in os.environ.items() if k != "MGDATA_ROOT"}, "MGDATA_CACHE": str(cache),
           "LP_NUM_THREADS": "1"}
    exe = str(Path(sys.executable).with_name("mgdata"))
    return subprocess.run([exe, "--root", str(root), *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=600)


def user_root(tmp: Path) -> Path:
    """A root started from the shipped recipes (docs/objects.md), with a clutter_dry copy whose target is
    the imported object and no cameras (speed)."""
    from mgdata.paths import recipes_dir

    root = tmp / "root"
    shutil.copytree(recipes_dir(), root / "recipes")
    recipe = root / "recipes" / "clutter_dry.toml"
    text = recipe.read_text()
    for old, new in (('models = ["cup/*", "mug/*", "teacup/*", "bottle/*", "box/*", "bowl/*"]',
                      f'models = ["{NAME}"]'),
                     ('cameras = ["front", "left", "right", "shoulder", "wrist"]', "cameras = []")):
        assert old in text
        text = text.replace(old, new)
    recipe.write_text(text)
    return root


def model_bytes(model: mujoco.MjModel) -> bytes:
    buf = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return buf.tobytes()


def colour_share(pixels: np.ndarray, rgb: tuple[int, int, int]) -> float:
    """Share of ``pixels`` (n, 3) whose chromaticity is ``rgb``'s (lighting scales brightness, not hue)."""
    p = pixels.astype(float) / np.maximum(pixels.sum(axis=1, keepdims=True), 1.0)
    c = np.asarray(rgb, dtype=float) / sum(rgb)
    return float(np.mean(np.abs(p - c).sum(axis=1) < 0.12))


def test_a_textured_obj_becomes_an_object_a_family_draws(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    root, cache = user_root(tmp_path), tmp_path / "cache"
    src = textured_box(tmp_path / "src")

    run = mgdata_run(root, cache, "objects", "import", src, "--name", NAME, "--mass", "0.15")
    assert run.returncode == 0, run.stdout + run.stderr
    folder = root / "objects" / "block"
    assert sorted(p.name for p in folder.iterdir()) == ["scanned_00.obj", "scanned_00.png", "scanned_00.toml"]
    from PIL import Image

    assert np.array_equal(np.asarray(Image.open(folder / "scanned_00.png")), checker())
    db = json.loads((root / "grasps" / "block.json").read_text())
    grasps = db["objects"][NAME]["grasps"]
    valid = [g for g in grasps if g["validation"]["status"] == "valid"]
    assert len(valid) >= 2, run.stdout  # the recipe's min_grasps

    # the model, from raw MuJoCo: texture coordinates, a material with the image, the image in the pixels
    from mgdata.sim.assets.library import forget_user_objects, get_model
    from mgdata.sim.scene import build_scene
    from mgdata.sim.taskspec import ObjectPlacement
    from tests.helpers.sim_tasks import task_with

    monkeypatch.setenv("MGDATA_ROOT", str(root))
    monkeypatch.setenv("MGDATA_CACHE", str(cache))
    forget_user_objects()
    try:
        assert get_model(NAME).geometry["textured"] is True
        scene = build_scene(task_with(ObjectPlacement("obj", NAME, (0.5, 0.0, 0.0), yaw=0.4)))
        scene.reset()
        m, d = scene.model, scene.data
        geom = m.geom("obj/visual")
        mesh = int(m.geom_dataid[geom.id])
        assert m.mesh_texcoordnum[mesh] == m.mesh_vertnum[mesh] > 0
        mat = int(m.geom_matid[geom.id])
        tex = int(m.mat_texid[mat, mujoco.mjtTextureRole.mjTEXROLE_RGB])
        assert mat >= 0 and tex >= 0 and (m.tex_width[tex], m.tex_height[tex]) == (32, 32)
        size = min(int(m.vis.global_.offwidth), int(m.vis.global_.offheight), 256)
        cam = mujoco.MjvCamera()
        cam.lookat[:] = scene.object_pose("obj")[0] + [0.0, 0.0, 0.04]
        cam.distance, cam.azimuth, cam.elevation = 0.35, 150.0, -35.0
        with mujoco.Renderer(m, size, size) as r:
            r.update_scene(d, cam)
            rgb = r.render()
            r.enable_segmentation_rendering()
            r.update_scene(d, cam)
            seg = r.render()
        mine = (seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM) & (seg[..., 0] == geom.id)
        assert mine.sum() > 300
        pixels = rgb[mine]
        assert colour_share(pixels, MAGENTA) > 0.2 and colour_share(pixels, CYAN) > 0.2
        assert colour_share(rgb[~mine], MAGENTA) < 0.001  # nothing else in the scene has the colours
    finally:
        forget_user_objects()

    # a family recipe draws it: kept demos that pass validate
    out = tmp_path / "ds"
    gen = mgdata_run(root, cache, "generate", "--family", "clutter_dry", "--n", "2", "--workers", "1",
                     "--out", out)
    assert gen.returncode == 0, gen.stdout + gen.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 2
    tasks = (out / "meta" / "tasks.parquet").read_bytes()
    assert b"block" in tasks  # the prompt names it by its category
    check = mgdata_run(root, cache, "validate", out)
    assert check.returncode == 0, check.stdout + check.stderr

    # the same file gives the same entry and the same compiled model
    again = tmp_path / "again"
    shutil.copytree(root / "recipes", again / "recipes")  # the same physics settings for the comparison
    run = mgdata_run(again, cache, "objects", "import", src, "--name", NAME, "--mass", "0.15", "--no-grasps")
    assert run.returncode == 0, run.stderr
    for name in ("scanned_00.obj", "scanned_00.png", "scanned_00.toml"):
        assert (again / "objects" / "block" / name).read_bytes() == (folder / name).read_bytes()
    monkeypatch.setenv("MGDATA_ROOT", str(again))
    forget_user_objects()
    try:
        other = build_scene(task_with(ObjectPlacement("obj", NAME, (0.5, 0.0, 0.0), yaw=0.4)))
        assert model_bytes(other.model) == model_bytes(m)  # the same compiled model from the other root
    finally:
        forget_user_objects()
    assert not (again / "grasps").exists()
    run = mgdata_run(again, cache, "objects", "import", src, "--name", NAME, "--mass", "0.2", "--no-grasps")
    assert run.returncode == 2 and "--replace" in run.stderr
    run = mgdata_run(again, cache, "objects", "import", src, "--name", NAME, "--mass", "0.2", "--no-grasps",
                     "--replace")
    assert run.returncode == 0, run.stderr
    assert "mass = 0.2\n" in (again / "objects" / "block" / "scanned_00.toml").read_text()


def test_a_glb_with_its_texture_embedded_gives_the_same_object(tmp_path: Path) -> None:
    import trimesh

    cache = tmp_path / "cache"
    obj = textured_box(tmp_path / "src")
    glb = tmp_path / "src" / "box.glb"
    trimesh.load(str(obj), force="mesh").export(glb)
    for source, root in ((obj, tmp_path / "a"), (glb, tmp_path / "b")):
        run = mgdata_run(root, cache, "objects", "import", source, "--name", NAME, "--mass", "0.15",
                         "--no-grasps")
        assert run.returncode == 0, run.stderr
    a, b = (tmp_path / r / "objects" / "block" for r in ("a", "b"))
    assert (a / "scanned_00.png").read_bytes() == (b / "scanned_00.png").read_bytes()

    def corners(path: Path) -> list[tuple[float, ...]]:  # (position, uv) of every vertex
        mesh = trimesh.load(str(path), force="mesh")
        return sorted(map(tuple, np.round(np.hstack([mesh.vertices, mesh.visual.uv]), 6)))

    assert corners(a / "scanned_00.obj") == corners(b / "scanned_00.obj")
    listed = mgdata_run(tmp_path / "b", cache, "objects", "list")
    assert listed.returncode == 0 and NAME in listed.stdout and "box.glb" in listed.stdout
