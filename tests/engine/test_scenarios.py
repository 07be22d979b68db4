"""OOD variants and locked scenarios: each builder changes its one factor only (checked on the raw
MuJoCo model and data), location variants pass the gate, scenarios are byte-deterministic and reload
bit-identically, and bad input is one error line."""

from __future__ import annotations

import dataclasses
import os
import re
import shutil
import string
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.engine.init_gate import base_task
from mgdata.errors import RecipeError
from mgdata.scenarios.store import (
    build_scenario,
    load_scenario,
    scenario_dir,
    variant,
    verify,
    write_manifest,
)
from mgdata.sim.config import load_sim_config
from mgdata.sim.renderer import CameraRig
from mgdata.sim.rooms import ROOM_NAMES, add_room
from mgdata.sim.scene import build_scene
from mgdata.sim.world import TABLE_X, TABLE_Y
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.base import draw_task
from mgdata.tasks.ood import GUARD, PALETTE
from mgdata.tasks.placer import LayoutRejected
from mgdata.tasks.recipe import family_recipes, load_recipe
from mgdata.tasks.variants import (
    environment_variant,
    language_variant,
    location_proposal,
    mean_colour,
    target_variant,
)
from tests.helpers.sim_tasks import kicked_states

MGDATA = [str(Path(sys.executable).parent / "mgdata")]
NAME_FIELDS = ("names", "paths", "names_map")
OVERVIEW = ("front", "left", "right", "shoulder")


def _model_fields(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Every array of the compiled model, except name storage (the model's name says its condition)."""
    out = {}
    for key in dir(model):
        if key.startswith("_") or key in NAME_FIELDS or key.startswith("name_"):
            continue
        value = getattr(model, key)
        if isinstance(value, np.ndarray):
            out[key] = value
    return out


def _changed_fields(a: mujoco.MjModel, b: mujoco.MjModel) -> set[str]:
    fa, fb = _model_fields(a), _model_fields(b)
    return {k for k in fa if fa[k].shape != fb[k].shape or not np.array_equal(fa[k], fb[k], equal_nan=True)}


def _files(root: Path) -> list[Path]:
    return sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file())


def _trajectory(task, kick: str) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Full physics states over 1.2 s: the arm sweeps its joints and ``kick`` slides into its neighbours."""
    return kicked_states(build_scene(task), kick, (0.0, -0.6, 0.0))


@pytest.fixture(scope="module")
def clutter():  # type: ignore[no-untyped-def]
    recipe = load_family_recipe("clutter_dry")
    return recipe, base_task(recipe, 0)


def test_target_recolour_changes_only_the_targets_colour(clutter) -> None:  # type: ignore[no-untyped-def]
    recipe, base = clutter
    task, prov = target_variant(base, recipe)
    a, b = build_scene(base), build_scene(task)
    assert _changed_fields(a.model, b.model) == {"geom_rgba"}
    changed = np.flatnonzero(np.any(a.model.geom_rgba != b.model.geom_rgba, axis=1))
    owners = {a.model.body(int(a.model.geom_bodyid[g])).name.split("/")[0] for g in changed}
    assert owners == {"target"}
    target = [
        g for g in range(a.model.ngeom) if a.model.body(int(a.model.geom_bodyid[g])).name.startswith("target")
    ]
    assert set(changed) == set(target)
    # palette entry task_id mod 6 or a later one, far from the object's mean colour; alpha kept
    assert prov["colour"] == PALETTE[(base.task_id + len(prov["skipped"])) % 6][0]
    assert np.linalg.norm(np.array(prov["tint"]) - np.array(mean_colour(base.object("target").model))) >= 0.35
    assert np.array_equal(a.model.geom_rgba[changed, 3], b.model.geom_rgba[changed, 3])
    # the physics trajectory is bit-identical
    assert np.array_equal(_trajectory(base, "target"), _trajectory(task, "target"))


def test_the_room_is_visual_only_and_changes_most_of_the_view(clutter) -> None:  # type: ignore[no-untyped-def]
    _, base = clutter
    room = dataclasses.replace(base, room=ROOM_NAMES[0])
    a, b = build_scene(base), build_scene(room)
    ma, mb = a.model, b.model
    assert (ma.nq, ma.nv, ma.nbody) == (mb.nq, mb.nv, mb.nbody)
    assert mujoco.mj_stateSize(ma, mujoco.mjtState.mjSTATE_INTEGRATION) == mujoco.mj_stateSize(
        mb, mujoco.mjtState.mjSTATE_INTEGRATION
    )
    is_room = np.array([mb.geom(g).name.startswith("room/") for g in range(mb.ngeom)])
    extra, kept = np.flatnonzero(is_room), np.flatnonzero(~is_room)  # kept: the base scene's geoms, in order
    assert len(kept) == ma.ngeom and len(extra) > 15
    recoloured = ("floor", "table/top")  # with the plain scene's walls: they take the room's colours
    plain = np.array([not ma.geom(g).name.startswith("wall_") and ma.geom(g).name not in recoloured
                      for g in range(ma.ngeom)])
    for f in (
        "type",
        "size",
        "pos",
        "quat",
        "friction",
        "contype",
        "conaffinity",
        "condim",
        "solref",
        "solimp",
        "margin",
        "gap",
        "priority",
        "rgba",
        "bodyid",
    ):
        assert np.array_equal(getattr(ma, f"geom_{f}")[plain], getattr(mb, f"geom_{f}")[kept][plain]), f
    assert (mb.geom_contype[extra] == 0).all() and (mb.geom_conaffinity[extra] == 0).all()
    assert (mb.geom_bodyid[extra] == 0).all()  # static, in the world body
    for f in (
        "body_pos",
        "body_quat",
        "body_mass",
        "body_inertia",
        "jnt_range",
        "dof_damping",
        "actuator_gainprm",
    ):
        assert np.array_equal(getattr(ma, f), getattr(mb, f)), f
    assert np.array_equal(_trajectory(base, "target"), _trajectory(room, "target"))
    with CameraRig(a, OVERVIEW, 96) as ra, CameraRig(b, OVERVIEW, 96) as rb:
        ia, ib = ra.render(), rb.render()
    for cam in OVERVIEW:
        changed = (np.abs(ia[cam].astype(int) - ib[cam].astype(int)).max(axis=2) > 10).mean()
        assert changed >= 0.30, (cam, changed)


ROOM_BOOKKEEPING = {"body_geomadr", "body_geomnum", "bvh_nodeid"}  # index maps shifted by the room's geoms
ROOM_VISUAL = {"tex_data", "mat_texrepeat", "mat_texid"}  # the floor and sky textures, their materials


def test_the_room_leaves_every_physics_field_of_robot_table_objects_and_cameras_equal() -> None:
    """Every compiled-model array, field by field: only geoms and lights are appended (the base's rows
    unchanged), only textures change values, and every body keeps exactly its own geoms."""
    recipe = load_family_recipe("jar")
    base = _placed(recipe, 0)
    task, _ = environment_variant(base, recipe)
    ma, mb = build_scene(base).model, build_scene(task).model
    fa, fb = _model_fields(ma), _model_fields(mb)
    assert fa.keys() == fb.keys()
    is_room = np.array([mb.geom(g).name.startswith("room/") for g in range(mb.ngeom)])
    kept = np.flatnonzero(~is_room)
    assert len(kept) == ma.ngeom and is_room.sum() > 15 and mb.nlight > ma.nlight
    grown = {k for k in fa if fa[k].shape != fb[k].shape}
    assert grown and all(k.startswith(("geom_", "light_", "tex_")) for k in grown), grown
    recoloured = [ma.geom(g).name.startswith("wall_") or ma.geom(g).name in ("floor", "table/top")
                  for g in range(ma.ngeom)]
    for k in sorted(k for k in grown if not k.startswith("tex_")):  # tex_: the room's floor texture is added
        rows = kept if k.startswith("geom_") else np.arange(ma.nlight)
        a, b = fa[k], fb[k][rows]
        if k == "geom_rgba":  # walls, floor, table top take the room's colours; nothing else
            assert np.array_equal(a[~np.array(recoloured)], b[~np.array(recoloured)]), k
        else:
            assert np.array_equal(a, b, equal_nan=True), k
    changed = {k for k in fa.keys() - grown if not np.array_equal(fa[k], fb[k], equal_nan=True)}
    assert changed <= ROOM_BOOKKEEPING | ROOM_VISUAL, changed - ROOM_BOOKKEEPING - ROOM_VISUAL
    for body in range(1, ma.nbody):  # every body but the world: the same geoms, in the same order
        ga = range(ma.body_geomadr[body], ma.body_geomadr[body] + ma.body_geomnum[body])
        gb = range(mb.body_geomadr[body], mb.body_geomadr[body] + mb.body_geomnum[body])
        assert [ma.geom(g).name for g in ga] == [mb.geom(g).name for g in gb]
        assert all(not is_room[g] for g in gb)
    assert all(mb.geom(g).name.startswith("room/") or g in kept for g in range(mb.ngeom))


@pytest.mark.parametrize("family", family_recipes())
def test_the_environment_variant_changes_most_of_every_overview_camera(family: str) -> None:
    recipe = load_family_recipe(family)
    base = _placed(recipe, 0)
    task, prov = environment_variant(base, recipe)
    cameras = [c for c in recipe.tasks.cameras if c in OVERVIEW]
    assert cameras
    with CameraRig(build_scene(base), cameras, 64) as ra, CameraRig(build_scene(task), cameras, 64) as rb:
        ia, ib = ra.render(), rb.render()
    for cam in cameras:
        changed = (np.abs(ia[cam].astype(int) - ib[cam].astype(int)).max(axis=2) > 10).mean()
        assert changed >= 0.30, (family, prov["room"], cam, changed)


def _bare_room(name: str) -> mujoco.MjModel:
    """A floor, a sky and a camera, in room ``name`` (the textures and material world.py names)."""
    spec = mujoco.MjSpec()
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
        width=8,
        height=8,
    )
    spec.add_texture(
        name="floor_tex",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        width=8,
        height=8,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
    )
    spec.add_material(name="floor_mat").textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor_tex"
    spec.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[4, 4, 0.1],
        pos=[0, 0, -0.75],
        material="floor_mat",
    )
    spec.worldbody.add_camera(name="left", pos=[0.2, 1.0, 0.9], xyaxes=[1, 0, 0, 0, 0.5, 0.86])
    add_room(spec, name, -0.75)
    return spec.compile()


@pytest.mark.slow
def test_every_room_style_builds_and_differs() -> None:
    pixels = []
    for name in ROOM_NAMES:
        model = _bare_room(name)
        assert (model.geom_contype[1:] == 0).all() and (model.geom_conaffinity[1:] == 0).all()
        rig = CameraRig.of_model(model, ("left",), 48, load_sim_config().render)
        try:
            mujoco.mj_forward(model, rig.data)
            pixels.append(rig.render()["left"])
        finally:
            rig.close()
    assert len(ROOM_NAMES) >= 8
    assert len({p.tobytes() for p in pixels}) == len(ROOM_NAMES)


def test_language_variant_is_the_same_scene_with_a_rewritten_prompt(clutter) -> None:  # type: ignore[no-untyped-def]
    recipe, base = clutter
    task, _, gate = variant(recipe, base, "language")
    assert task.prompt != base.prompt and gate["passed"]
    assert _changed_fields(build_scene(base).model, build_scene(task).model) == set()
    assert dataclasses.replace(task, prompt=base.prompt, condition="base") == dataclasses.replace(base)


def _names(recipe, prompt: str) -> list[str]:  # type: ignore[no-untyped-def]
    """The object names filling the recipe's prompt template (a field used twice must match the same name)."""
    seen: set[str] = set()
    parts = []
    for lit, f, _, _ in string.Formatter().parse(recipe.prompt):
        parts.append(re.escape(lit))
        if f:
            parts.append(f"(?P={f})" if f in seen else f"(?P<{f}>.+?)")
            seen.add(f)
    regex = "".join(parts)
    return list(re.fullmatch(regex, prompt).groupdict().values())  # type: ignore[union-attr]


def _placed(recipe, k: int):  # type: ignore[no-untyped-def]
    """The first draw of task ``k`` the placer accepts (placement only, no gate)."""
    for d in range(recipe.tasks.max_draws):
        try:
            return draw_task(recipe, k, d)
        except LayoutRejected:
            continue
    raise AssertionError(f"{recipe.family} task {k}: no layout draw")


def _guard_counts(text: str) -> dict[str, int]:
    return {w: len(re.findall(rf"\b{re.escape(w)}\b", text, re.I)) for w in GUARD}


def test_language_variants_of_every_prompt_keep_names_and_add_no_guard_word() -> None:
    for family in family_recipes():
        recipe = load_family_recipe(family)
        for k in range(recipe.tasks.count):
            base = _placed(recipe, k)
            task, _ = language_variant(base, recipe)
            assert task.prompt != base.prompt
            for name in _names(recipe, base.prompt):
                assert name in task.prompt, (family, k, name)
            before, after = _guard_counts(base.prompt), _guard_counts(task.prompt)
            assert all(after[w] <= before[w] for w in GUARD), (family, k, task.prompt)


@settings(max_examples=60, deadline=None)
@given(
    name=st.text(alphabet="abcdefghijklmnopqrstuvwxyz ", min_size=1, max_size=20).map(str.strip).filter(bool)
    | st.sampled_from(["pick up truck", "close pin", "carry-on bag", "into box"])
)
def test_language_swaps_never_touch_a_filled_in_name(name: str) -> None:
    recipe = dataclasses.replace(load_recipe("clutter_dry"))
    base = dataclasses.replace(_placed(recipe, 0), prompt=recipe.prompt.format(target=name))
    task, _ = language_variant(base, recipe)
    assert task.prompt.startswith(f"Lift the {name} on the table")
    assert " in the green goal sphere" in task.prompt


def test_location_variant_moves_objects_and_passes_the_gate() -> None:
    recipe = load_family_recipe("jar")
    base = base_task(recipe, 0)
    task, prov, gate = variant(recipe, base, "location")
    assert gate["passed"] and len(task.gate["grasps"]) >= recipe.tasks.min_grasps
    a, b = build_scene(base), build_scene(task)
    for f in (
        "geom_size",
        "geom_type",
        "geom_friction",
        "body_mass",
        "body_inertia",
        "jnt_range",
        "cam_fovy",
    ):
        assert np.array_equal(getattr(a.model, f), getattr(b.model, f)), f
    ma = a.model
    robot_and_table = [i for i in range(ma.nbody) if not ma.body(i).name.startswith(("jar", "food", "goal"))]
    assert np.array_equal(ma.body_pos[robot_and_table], b.model.body_pos[robot_and_table])
    assert np.array_equal(ma.cam_pos, b.model.cam_pos) and np.array_equal(ma.cam_quat, b.model.cam_quat)
    # raw data: the jar moved by about the recorded offset, the goal with it (pack), all at rest on the table
    jar_a, jar_b = a.data.xpos[ma.body("jar").id], b.data.xpos[b.model.body("jar").id]
    offset = np.array(prov["units"][0]["offset"])
    assert np.linalg.norm(jar_b[:2] - jar_a[:2]) > 0.02
    assert np.allclose(jar_b[:2] - jar_a[:2], offset, atol=0.005)
    goal_a, goal_b = a.data.xpos[ma.body("goal").id], b.data.xpos[b.model.body("goal").id]
    assert np.allclose(goal_b[:2] - goal_a[:2], offset, atol=1e-9)
    d = b.data
    free = [
        b.model.jnt_dofadr[j]
        for j in range(b.model.njnt)
        if b.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]
    assert max(np.linalg.norm(d.qvel[i : i + 3]) for i in free) < recipe.tasks.rest_linear_speed
    assert all(c.dist > -0.002 for c in d.contact[: d.ncon])
    assert TABLE_X[0] < jar_b[0] < TABLE_X[1] and TABLE_Y[0] < jar_b[1] < TABLE_Y[1] and jar_b[2] > -0.01


@pytest.mark.slow
def test_a_location_rule_no_draw_can_meet_is_an_error_not_a_dropped_variant(tmp_path: Path) -> None:
    recipes = tmp_path / "recipes"
    shutil.copytree(Path(load_recipe("jar").path).parent, recipes)
    text = (
        (recipes / "jar.toml")
        .read_text()
        .replace("fraction = [0.8, 1.5]", "fraction = [0.8, 1.5]\ntries = 2")
        .replace("min_grasps = 2 ", "min_grasps = 400 ")  # no displaced jar can meet this
    )
    (recipes / "jar.toml").write_text(text)
    recipe = load_family_recipe(recipes / "jar.toml")
    base = base_task(load_family_recipe("jar"), 0)
    with pytest.raises(RecipeError, match=r"task 0: no location variant passed the gate in 2 tries"):
        variant(recipe, base, "location")


@pytest.mark.slow
def test_scenarios_are_byte_deterministic_across_processes_and_reload_bit_identically(tmp_path: Path) -> None:
    cmd = [*MGDATA, "scenarios", "build", "--family", "jar", "--tasks", "1", "--condition", "target"]
    proc = subprocess.run([*cmd, "--out", str(tmp_path / "a")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    recipe = load_family_recipe("jar")
    entry = build_scenario(recipe, 1, "target", tmp_path / "b")  # in this process
    write_manifest(tmp_path / "b")
    assert entry["path"] == "jar/task_0001/target"
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert len([f for f in files if f.parts[0] == "chunks"]) >= 20  # the model's chunks
    assert len(files) == len(_files(tmp_path / "b"))  # + state, metadata, manifest
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    model, data, meta = load_scenario(scenario_dir(tmp_path / "a", "jar", 1, "target"))
    scene = build_scene(variant(recipe, base_task(recipe, 1), "target")[0])
    assert np.array_equal(data.qpos, scene.data.qpos) and np.array_equal(data.qvel, scene.data.qvel)
    assert np.array_equal(model.geom_rgba, scene.model.geom_rgba)
    assert meta["prompt_forms"]["ltl"].endswith("& G !jar_dropped & G jar_upright")
    assert list(verify(tmp_path / "a")) == [("jar/task_0001/target", None)]
    (tmp_path / "a" / "jar/task_0001/target/state.npy").write_bytes(b"x")  # tampered
    assert "SHA-256 differs" in str(next(iter(verify(tmp_path / "a")))[1])


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        ('[ood]\ntarget = "lid"', "[ood] target = 'lid': expected one of the layout's roles"),
        ("[ood]\ncolour = 1", "[ood]: unknown key(s) ['colour']"),
        ('[ood.location]\ngrouping = "row"', "[ood].location grouping = 'row': expected one of"),
        ('[ood.language]\nswaps = [["close", "close safely"]]', "introduces the guarded word(s) ['safely']"),
        ('[ood.environment]\nrooms = ["moon"]', "[ood].environment rooms = ['moon']"),
    ],
)
def test_malformed_ood_is_a_recipe_error(tmp_path: Path, edit: str, message: str) -> None:
    shutil.copytree(Path(load_recipe("jar").path).parent, tmp_path / "recipes")
    path = tmp_path / "recipes" / "jar.toml"
    text = path.read_text()
    path.write_text(text[: text.index("[ood]")] + edit + "\n")
    with pytest.raises(RecipeError) as err:
        load_recipe(path)
    assert message in str(err.value) and str(path) in str(err.value)


@pytest.mark.slow
def test_malformed_ood_is_one_error_line_from_the_cli(tmp_path: Path) -> None:
    root = tmp_path / "root"
    shutil.copytree(Path(load_recipe("jar").path).parent, root / "recipes")
    (root / "grasps").symlink_to(Path(load_recipe("jar").path).parent.parent / "grasps")
    path = root / "recipes" / "jar.toml"
    path.write_text(path.read_text().replace('grouping = "pack"', 'grouping = "row"'))
    proc = subprocess.run(
        [*MGDATA, "scenarios", "build", "--family", "jar", "--out", str(tmp_path / "s")],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "MGDATA_ROOT": str(root)},
    )
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: ") and "[ood].location grouping = 'row'" in lines[0]
    assert not (tmp_path / "s").exists()


def test_unknown_family_is_one_error_line(tmp_path: Path) -> None:
    proc = subprocess.run(
        [*MGDATA, "scenarios", "build", "--family", "nosuch", "--out", str(tmp_path / "s")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "no recipe for family 'nosuch'" in lines[0], (
        proc.stderr
    )
    assert not (tmp_path / "s").exists()


@pytest.mark.slow
def test_bad_condition_tasks_and_folder_are_one_error_line(tmp_path: Path) -> None:
    for args, message in (
        (("--family", "jar", "--condition", "lighting"), "--condition 'lighting'"),
        (("--family", "jar", "--tasks", "99"), "jar has tasks 0 … 25, not 99"),
    ):
        proc = subprocess.run(
            [*MGDATA, "scenarios", "build", *args, "--out", str(tmp_path / "s")],
            capture_output=True,
            text=True,
            timeout=600,
        )
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1 and message in lines[0], (args, proc.stderr)
    assert not (tmp_path / "s").exists()
    proc = subprocess.run(
        [*MGDATA, "scenarios", "list", "--out", str(tmp_path / "none")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert (
        proc.returncode == 2 and proc.stderr.startswith("error: ") and "no scenario manifest" in proc.stderr
    )


def test_a_scenario_is_byte_deterministic_and_verifies(tmp_path: Path) -> None:
    recipe = load_family_recipe("jar")
    for out in ("a", "b"):
        build_scenario(recipe, 0, "environment", tmp_path / out)
        write_manifest(tmp_path / out)
    files = _files(tmp_path / "a")
    assert files == _files(tmp_path / "b") and len(files) > 4
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    _, data, meta = load_scenario(scenario_dir(tmp_path / "a", "jar", 0, "environment"))
    scene = build_scene(variant(recipe, base_task(recipe, 0), "environment")[0])
    assert meta["room"] and np.array_equal(data.qpos, scene.data.qpos)
    assert list(verify(tmp_path / "a")) == [("jar/task_0000/environment", None)]
    # the store keeps shared bytes once: a second condition of the task adds only a few new chunks
    chunks = tmp_path / "a" / "chunks"
    before = {p: p.stat().st_size for p in chunks.rglob("*.gz")}
    build_scenario(recipe, 0, "language", tmp_path / "a")
    write_manifest(tmp_path / "a")
    added = {p: p.stat().st_size for p in chunks.rglob("*.gz")}.keys() - before.keys()
    model, _, lang = load_scenario(scenario_dir(tmp_path / "a", "jar", 0, "language"))
    assert lang["model_size"] > 5_000_000 and len(lang["model_chunks"]) > 50
    share = sum(p.stat().st_size for p in added) / sum(before.values())
    assert 0 < share < 0.1, (len(added), share)
    assert _changed_fields(model, build_scene(base_task(recipe, 0)).model) == set()
    next(iter(added)).write_bytes(next(iter(before)).read_bytes())  # a chunk with other content
    problems = dict(verify(tmp_path / "a"))
    assert problems["jar/task_0000/environment"] is None
    assert "SHA-256 differs from its name" in str(problems["jar/task_0000/language"])
    (tmp_path / "a" / "jar/task_0000/environment/state.npy").write_bytes(b"x")  # tampered
    assert "SHA-256 differs" in str(next(iter(verify(tmp_path / "a")))[1])


def test_units_move_rigidly_and_an_axis_direction_is_followed(tmp_path: Path) -> None:
    shutil.copytree(Path(load_recipe("clutter_dry").path).parent, tmp_path / "recipes")
    path = tmp_path / "recipes" / "clutter_dry.toml"
    text = path.read_text()
    path.write_text(
        text[: text.index("[ood]")] + '[ood.location]\ngrouping = "units"\n'
        'units = [["target"], ["obstacle"]]\ndirection = { of = "target", axis = [1.0, 0.0] }\n'
    )
    recipe = load_recipe(path)
    base = _placed(recipe, 2)
    moved = 0
    for attempt in range(8):
        try:
            task, prov = location_proposal(base, recipe, attempt)
        except LayoutRejected:
            continue
        moved += 1
        delta = {o.name: np.subtract(task.object(o.name).pos, o.pos) for o in base.objects}
        obstacles = [d for n, d in delta.items() if n.startswith("obstacle")]
        assert all(np.allclose(d, obstacles[0], atol=1e-12) for d in obstacles)  # one rigid unit
        axis = np.array([np.cos(base.object("target").yaw), np.sin(base.object("target").yaw)])
        for d in (delta["target"], obstacles[0]):
            assert abs(d[2]) == 0.0 and np.linalg.norm(d[:2]) > 0.0
            assert abs(abs(np.dot(d[:2], axis)) - np.linalg.norm(d[:2])) < 1e-9 or prov["fallback"]
        assert task.goal == base.goal and [u["objects"][0] for u in prov["units"]] == ["target", "obstacle_0"]
    assert moved >= 1
