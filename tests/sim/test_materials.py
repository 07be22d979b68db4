"""The look (``mgdata.sim.materials``): every visible surface has a material of what it is, textures are
generated deterministically and show in the images, the wrist camera still sees the fingers, and none of it
touches physics (raw MuJoCo model fields and a contact-rich trajectory, bit for bit)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from mgdata.errors import RecipeError
from mgdata.sim import robot
from mgdata.sim.cameras import WRIST
from mgdata.sim.config import load_sim_config, sim_config_from_dict
from mgdata.sim.materials import FINISHES, Look
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.sim.textures import KINDS, texture
from tests.helpers.sim_tasks import jar_task, kicked_states

PHYSICS_FIELDS = ("body_mass", "body_inertia", "body_pos", "body_quat", "geom_size", "geom_pos", "geom_quat",
                  "geom_friction", "geom_contype", "geom_conaffinity", "geom_solref", "geom_solimp",
                  "geom_margin", "dof_damping", "jnt_range", "actuator_gainprm", "actuator_biasprm")


def _task():  # type: ignore[no-untyped-def]
    """The jar scene plus a carton and a mug: glass, metal, food, cardboard and ceramic surfaces."""
    return jar_task(extra=(ObjectPlacement("box", "box/carton_00", (0.45, -0.25, 0.0)),
                           ObjectPlacement("mug", "mug/handled_00", (0.6, 0.25, 0.0))))


def _plain_look_scene() -> Scene:
    sim = load_sim_config()
    flat = dataclasses.replace(sim.look, textures=False, key_light=0.9, fill_light=0.0, ambient=0.6,
                               headlight=0.0, key_dir=(0.0, 0.0, -1.0), walls=(0.2, 0.2, 0.2))
    return build_scene(_task(), sim=dataclasses.replace(sim, look=flat))


def _trajectory(scene: Scene) -> np.ndarray:
    """States of 1.2 s in which the arm sweeps and the carton is kicked into the jar (contacts)."""
    scene.reset()
    return kicked_states(scene, "box", (0.2, 0.6, 0.0), every=20)


def test_the_look_changes_no_physics_field_and_no_state() -> None:
    a, b = build_scene(_task()), _plain_look_scene()
    for f in PHYSICS_FIELDS:
        assert np.array_equal(getattr(a.model, f), getattr(b.model, f)), f
    assert a.model.opt.timestep == b.model.opt.timestep and a.model.stat.extent == b.model.stat.extent
    added = [g for g in range(a.model.ngeom) if a.model.geom(g).name.startswith("wall_")]
    assert len(added) == 4
    assert (a.model.geom_contype[added] == 0).all() and (a.model.geom_conaffinity[added] == 0).all()
    assert (a.model.geom_bodyid[added] == 0).all() and (a.model.geom_group[added] == 2).all()
    assert np.array_equal(a.snapshot(), b.snapshot())  # the settled initial states
    assert np.array_equal(_trajectory(a), _trajectory(b))


def test_every_visible_object_geom_wears_its_categorys_finish() -> None:
    scene = build_scene(_task())
    m, look = scene.model, scene.sim.look
    for g in range(m.ngeom):
        name = m.geom(g).name
        head = name.split("/", 1)[0]
        if head not in scene.object_names or m.geom_group[g] not in (0, 2):
            continue
        category = scene.objects[head].category
        expected = "glass" if m.geom_rgba[g, 3] < 1.0 else look.finish(category)
        assert m.geom_matid[g] >= 0, name
        assert m.material(int(m.geom_matid[g])).name == f"finish_{expected}", name
        kind, specular, _ = FINISHES[expected]
        assert m.mat_specular[m.geom_matid[g]] == pytest.approx(specular)
        tex = m.mat_texid[m.geom_matid[g], mujoco.mjtTextureRole.mjTEXROLE_RGB]
        assert (tex >= 0) == (kind is not None), name
    assert {look.finish(scene.objects[n].category) for n in ("box", "mug")} == {"cardboard", "ceramic"}
    for name, material in (("table/top", "table_mat"), ("floor", "floor_mat"), ("wall_back", "wall_mat")):
        assert m.material(int(m.geom_matid[m.geom(name).id])).name == material


def test_textures_are_deterministic_tileable_and_not_flat() -> None:
    for kind in KINDS:
        a, b = texture(kind, 64, 7), texture(kind, 64, 7)
        assert a.tobytes() == b.tobytes() and a.shape == (64, 64, 3) and a.dtype == np.uint8
        assert texture(kind, 64, 8).tobytes() != a.tobytes()
        grey = a[..., 0].astype(float)
        assert grey.std() > 1.0, kind  # a surface, not a flat colour
        if kind != "planks":  # (planks put a joint on the seam, as on every fourth of the tile)
            # tileable: the jump across the wrap-around seam is no larger than between neighbouring rows
            inside = np.abs(np.diff(grey, axis=0)).mean()
            seam = np.abs(grey[0] - grey[-1]).mean()
            assert seam <= 3.0 * inside + 1.0, kind
    m1, m2 = build_scene(_task()).model, build_scene(_task()).model
    assert m1.ntex >= 6 and m1.tex_data.tobytes() == m2.tex_data.tobytes()


def _segmentation(scene: Scene, camera: str, size: int) -> np.ndarray:
    """Geom id per pixel (−1: none) of ``camera``."""
    r = mujoco.Renderer(scene.model, size, size)
    try:
        r.enable_segmentation_rendering()
        mujoco.mj_forward(scene.model, scene.data)
        r.update_scene(scene.data, camera=camera)
        seg = r.render()
    finally:
        r.close()
    return np.where(seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM, seg[..., 0], -1)


def test_the_wood_shows_on_the_table_and_the_fingers_in_the_wrist_view() -> None:
    textured, flat = build_scene(_task()), _plain_look_scene()
    with CameraRig(textured, ("front",), 128) as ra, CameraRig(flat, ("front",), 128) as rb:
        ia, ib = ra.render()["front"], rb.render()["front"]
    top = _segmentation(textured, "front", 128) == textured.model.geom("table/top").id
    assert top.mean() > 0.3
    pairs = top[:, 1:] & top[:, :-1]  # horizontal neighbours both on the table: the grain's local contrast
    grain, plain = (np.abs(np.diff(img.astype(float).mean(axis=2), axis=1))[pairs].mean() for img in (ia, ib))
    assert grain > 2.0 and grain > 4.0 * plain, (grain, plain)
    # the fingers sit 4-11 cm in front of the wrist camera: inside the near plane they would vanish
    m = textured.model
    seen = _segmentation(textured, WRIST, 128)
    fingers = [m.body(n).id for n in robot.FINGER_BODIES]
    assert np.isin(m.geom_bodyid[seen[seen >= 0]], fingers).sum() > 100


@pytest.mark.parametrize(("raw", "words"), [
    ({"look": {"colour": 1}}, "unknown key [look] colour"),
    ({"look": {"key_dir": [0.0, 0.0, 1.0]}}, "must point down"),
    ({"look": {"texture_size": 4}}, "texture_size"),
    ({"look": {"ceramic": ["mug"], "metal": ["mug"]}}, "both ceramic and metal"),
    ({"look": {"ambient": 2.0}}, "ambient"),
])
def test_a_bad_look_is_one_error_naming_the_key(raw: dict, words: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(RecipeError, match=words.replace("[", r"\[").replace("]", r"\]")):
        sim_config_from_dict(raw, "sim.toml")


def test_the_shipped_look_is_the_documented_default() -> None:
    assert load_sim_config().look == Look()
