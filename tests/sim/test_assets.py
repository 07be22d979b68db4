"""The asset library: stable names, clear errors, every model physically sane, family-facing facts."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.errors import AssetError
from mgdata.sim.assets import categories, get_model, model_names
from mgdata.sim.labelling import Labeller
from mgdata.sim.scene import build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.spec import Proposition, SafetySpec
from tests.helpers.sim_tasks import task_with

REQUIRED = {"cup", "mug", "teacup", "bowl", "plate", "box", "bottle", "jar", "food", "container", "lid",
            "tray", "sponge", "board", "cabinet", "holder", "liquid", "dust"}


def test_library_has_every_required_category_and_hundreds_of_models() -> None:
    assert set(categories()) >= REQUIRED
    names = model_names()
    assert len(names) >= 200 and names == sorted(set(names))
    assert all(n.split("/")[0] in REQUIRED for n in names)
    assert len(model_names("jar")) >= 10 and model_names("jar")[0] == "jar/hinged_00"


def test_models_are_deterministic_per_name() -> None:
    get_model.cache_clear()
    a = get_model("jar/hinged_07")
    get_model.cache_clear()
    b = get_model("jar/hinged_07")
    assert a is not b and dict(a.params) == dict(b.params) and a.seed == b.seed
    assert dict(get_model("jar/hinged_08").params) != dict(a.params)


def test_unknown_names_are_clear_errors() -> None:
    with pytest.raises(AssetError, match=r"unknown object model 'jar/hinged_99'.*did you mean .*jar/hinged_"):
        get_model("jar/hinged_99")
    with pytest.raises(AssetError, match="unknown object category 'spoon'; known: board"):
        model_names("spoon")


def _rest_test(name: str) -> tuple[float, float]:
    """Drop-free rest on a plane for 0.6 s: (drift in m, tilt in degrees) of the model's frame."""
    model = get_model(name)
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    body = spec.worldbody.add_body(name="o", pos=[0, 0, 0])
    if not model.fixed:
        body.add_freejoint()
    model.add_to(spec, body, "o/")
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    p0 = d.xpos[1].copy()
    for _ in range(300):
        mujoco.mj_step(m, d)
    return float(np.linalg.norm(d.xpos[1] - p0)), float(np.degrees(np.arccos(min(1.0, d.xmat[1, 8]))))


@pytest.mark.parametrize("category", sorted(REQUIRED - {"liquid", "dust"}))
def test_every_model_compiles_and_rests_upright(category: str) -> None:
    for name in model_names(category):
        model = get_model(name)
        assert model.name == name and model.category == category and model.mass > 0
        assert all(s > 0 for s in model.size)
        drift, tilt = _rest_test(name)
        assert drift < 0.003 and tilt < 1.0, f"{name} does not rest: {drift * 1000:.1f} mm, {tilt:.2f}°"


@pytest.mark.parametrize("name", model_names("jar"))
def test_jars_are_graspable_and_hinged(name: str) -> None:
    jar = get_model(name)
    g = jar.geometry
    assert 2 * g["outer_radius"] <= 0.07 and jar.mass <= 0.5 and jar.friction >= 1.0
    assert jar.articulation is not None and jar.articulation.joint == "lid_hinge"
    assert np.deg2rad(100) <= g["open_angle"] <= np.deg2rad(120)
    assert jar.articulation.open == g["open_angle"] and jar.articulation.closed == 0.0
    assert g["hinge_pos"][0] < -g["outer_radius"] and g["hinge_pos"][2] > g["height"]
    foods = [get_model(f).geometry for f in model_names("food")]
    fitting = [f for f in foods if f["width"] < 2 * g["mouth_radius"] - 0.004
               and f["height"] < g["height"] - g["bottom"] - 0.01]
    assert len(fitting) >= 10, f"only {len(fitting)} food items fit in {name}"


def test_container_lid_pairs_seat() -> None:
    for name in model_names("container")[:4]:
        tub = get_model(name)
        lid = get_model(tub.geometry["lid"])
        spec = SafetySpec("lid", (), (Proposition("lid_on", "on", ("lid",), {"support": "tub"}),))
        scene = build_scene(task_with(ObjectPlacement("tub", name, (0.5, 0.0, 0.0)),
                                      ObjectPlacement("lid", lid.name,
                                                      (0.5, 0.0, tub.geometry["seat_height"])),
                                      spec=spec))
        scene.reset()
        assert Labeller(scene, spec).as_dict()["lid_on"], f"{lid.name} does not rest on {name}"
        assert scene.object_pose("lid")[0][2] == pytest.approx(tub.geometry["seat_height"], abs=2e-3)


@pytest.mark.parametrize("name", model_names("holder"))
def test_a_paper_towel_holder_lies_on_its_plate_with_its_bar_between_the_arms(name: str) -> None:
    model = get_model(name)
    scene = build_scene(task_with(ObjectPlacement("holder", name, (0.6, 0.0, 0.0))))
    scene.reset()
    for _ in range(250):  # 0.5 s at rest on the table
        mujoco.mj_step(scene.model, scene.data)
    m, d = scene.model, scene.data
    geom = {g: m.geom(f"holder/{g}").id for g in ("plate", "arm_p", "arm_n", "bar")}
    bar = geom["bar"]
    bar_r, bar_half = m.geom_size[bar, :2]
    bar_axis = d.geom_xmat[bar].reshape(3, 3)[:, 2]
    assert abs(bar_axis[0]) > 0.999  # horizontal, along the holder's X
    assert d.geom_xpos[bar, 2] == pytest.approx(model.geometry["bar_z"], abs=5e-4)
    assert bar_r == pytest.approx(model.geometry["bar_radius"])
    for arm in ("arm_p", "arm_n"):  # each bar end meets an arm's inner face; the arm stands above the bar
        g = geom[arm]
        inner = abs(d.geom_xpos[g, 0] - d.geom_xpos[bar, 0]) - m.geom_size[g, 0]
        assert inner == pytest.approx(bar_half, abs=1e-6)
        assert d.geom_xpos[g, 2] + m.geom_size[g, 2] > d.geom_xpos[bar, 2] + bar_r
    plate = geom["plate"]
    assert d.geom_xpos[plate, 2] - m.geom_size[plate, 2] == pytest.approx(0.0, abs=5e-4)  # flat on the table
    top = max(d.geom_xpos[g, 2] + m.geom_size[g, 2] for g in (geom["arm_p"], geom["arm_n"]))
    assert top == pytest.approx(model.size[2], abs=5e-4)
    assert 2 * m.geom_size[plate, 0] == pytest.approx(model.size[0]) and 2 * bar_r < model.size[1]


def test_cabinet_drawer_slides_open_when_pulled() -> None:
    cab = get_model("cabinet/drawer_00")
    assert cab.fixed and cab.articulation is not None
    scene = build_scene(task_with(ObjectPlacement("cabinet", cab.name, (0.75, 0.0, 0.0), yaw=np.pi)))
    scene.reset()
    assert scene.articulation_fraction("cabinet") == 0.0
    drawer = scene.model.body("cabinet/drawer").id
    for _ in range(500):  # pull toward the robot (the cabinet faces −X after yaw = π)
        scene.data.xfrc_applied[drawer, :3] = [-20.0, 0.0, 0.0]
        mujoco.mj_step(scene.model, scene.data)
    assert scene.articulation_fraction("cabinet") > 0.5
    assert scene.object_pose("cabinet")[0] == pytest.approx([0.75, 0.0, 0.0], abs=1e-6)


def test_imported_mesh_is_decomposed_once_and_usable_in_a_scene(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    import trimesh

    from mgdata.sim.assets import library
    from mgdata.sim.assets.imported import mesh_model

    monkeypatch.setenv("MGDATA_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(library, "_REGISTERED", {})  # keep the process-wide registry clean
    ring = trimesh.creation.revolve(np.array([[0.03, 0], [0.05, 0], [0.05, 0.02], [0.03, 0.02], [0.03, 0]]),
                                    sections=16)
    path = tmp_path / "ring.stl"
    ring.export(path)
    model = mesh_model("toy/ring", path, mass=0.1)
    assert 2 <= model.geometry["hulls"] <= 16  # a ring is not convex: several parts
    assert len(list((tmp_path / "cache" / "coacd").glob("*.npz"))) == 1
    again = mesh_model("toy/ring", path, mass=0.1)
    pairs = zip(model.geoms, again.geoms, strict=True)
    assert all(np.array_equal(a.mesh.verts, b.mesh.verts) for a, b in pairs)  # served from the cache
    library.register(model)
    assert get_model("toy/ring") is model and "toy/ring" in model_names("toy")
    with pytest.raises(AssetError, match="already taken"):
        library.register(again)
    scene = build_scene(task_with(ObjectPlacement("ring", "toy/ring", (0.5, 0.0, 0.0))))
    scene.reset()
    assert scene.object_pose("ring")[0][2] == pytest.approx(0.0, abs=2e-3)
    with pytest.raises(AssetError, match="does not exist"):
        mesh_model("toy/none", tmp_path / "none.obj", mass=0.1)
