"""Appearance randomisation: per-episode draws change only what the cameras see (physics, actions and labels
bit for bit), reproduce from the recorded seed, keep distractors clear of everything that moves (checked
from raw MuJoCo geometry of every frame), and ``mgdata render --appearance K`` makes K draws of an existing
dataset whose draw 0 is generation's own, byte for byte."""

from __future__ import annotations

import colorsys
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.errors import RecipeError
from mgdata.record.appearance import episode_appearance
from mgdata.record.physics import set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.sim.appearance_draw import AppearanceSettings, parse_appearance
from mgdata.sim.renderer import CameraRig
from tests.helpers.generate import jar_recipe

CAMERAS = ("front", "wrist")
MGDATA = [str(Path(sys.executable).parent / "mgdata")]


def _generate(tmp: Path, name: str, appearance: bool) -> Path:
    table = "[appearance]\nenabled = true\ndistractors = [2, 3]\n\n[params]"
    edits = (("[params]", table),) if appearance else ()
    recipe = jar_recipe(tmp / name, cameras=CAMERAS, image_size=48, edits=edits)
    out = tmp / name / "data"
    proc = subprocess.run([*MGDATA, "generate", "--family", "jar", "--n", "1", "--tasks", "0", "--workers",
                           "1", "--recipe", str(recipe), "--out", str(out)], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    tmp = tmp_path_factory.mktemp("appearance")
    return _generate(tmp, "plain", False), _generate(tmp, "drawn", True)


def test_appearance_changes_the_pictures_and_nothing_else(pair: tuple[Path, Path]) -> None:
    plain, drawn = (DatasetReader(p) for p in pair)
    a, b = plain.episode(0), drawn.episode(0)
    assert np.array_equal(a.physics_state, b.physics_state)
    assert np.array_equal(a.action, b.action) and np.array_equal(a.state, b.state)
    assert np.array_equal(a.labels, b.labels) and np.array_equal(a.violated, b.violated)
    assert plain.scene_mjb(0) == drawn.scene_mjb(0)  # the stored scene is the one physics ran in
    for cam in CAMERAS:
        diff = np.abs(plain.frames(0, cam).astype(int) - drawn.frames(0, cam).astype(int)).mean()
        assert diff > 5.0, (cam, diff)
    record = drawn.record(0).meta.variation["appearance"]
    assert record["k"] == 0 and set(record["surfaces"]) == {"table", "floor", "walls"}
    assert "appearance" not in plain.record(0).meta.variation


def test_a_draw_reproduces_from_the_recorded_seed_and_k_changes_it(pair: tuple[Path, Path]) -> None:
    reader = DatasetReader(pair[1])
    model = mujoco.MjModel.from_binary_path("s.mjb", {"s.mjb": reader.scene_mjb(0)})
    states, meta = list(reader.episode(0).physics_state), reader.record(0).meta
    settings = parse_appearance({"enabled": True, "distractors": [2, 3]}, "test")
    first = episode_appearance(settings, model, states, meta, k=0)
    assert first.record() == reader.record(0).meta.variation["appearance"]
    assert episode_appearance(settings, model, states, meta, k=0).record() == first.record()
    assert episode_appearance(settings, model, states, meta, k=1).record() != first.record()
    # the rig renders the same bytes for the same draw, and the stored frames are what it renders
    data = mujoco.MjData(model)
    with CameraRig.of_model(model, CAMERAS, 48, settings_render()) as rig:
        rig.set_appearance(first)
        set_physics_state(model, data, states[10])
        once = rig.render(data)
        rig.set_appearance(episode_appearance(settings, model, states, meta, k=1))
        rig.set_appearance(first)
        again = rig.render(data)
    for cam in CAMERAS:
        assert once[cam].tobytes() == again[cam].tobytes()


def test_the_recipe_colours_are_what_the_surfaces_are_drawn_from(pair: tuple[Path, Path]) -> None:
    reader = DatasetReader(pair[1])
    model = mujoco.MjModel.from_binary_path("s.mjb", {"s.mjb": reader.scene_mjb(0)})
    states, meta = list(reader.episode(0).physics_state), reader.record(0).meta
    walls = ((0.2, 0.4, 0.6), (0.6, 0.4, 0.2))
    settings = parse_appearance({"enabled": True, "table_colors": [[1.0, 0.0, 0.0]],
                                 "wall_colors": [list(c) for c in walls]}, "test")
    top = model.geom("table/top").id
    for k in range(6):
        draw = episode_appearance(settings, model, states, meta, k=k)
        copy = mujoco.MjModel.from_binary_path("s.mjb", {"s.mjb": reader.scene_mjb(0)})
        draw.apply(copy)
        drawn = draw.record()["surfaces"]["table"]["rgb"]
        assert drawn[1] == drawn[2] == 0.0 and 0.9 <= drawn[0] <= 1.0, drawn
        # what the cameras see (the rig's model copy, raw): that red, with the table's own small tint
        hue = colorsys.rgb_to_hsv(*(float(x) for x in copy.geom_rgba[top, :3]))[0]
        assert min(hue, 1.0 - hue) <= settings.hue + 1e-6, copy.geom_rgba[top]
        wall = np.asarray(draw.record()["surfaces"]["walls"]["rgb"])
        assert any(np.all(np.abs(wall - np.asarray(c)) <= 0.1 * np.asarray(c) + 1e-9) for c in walls), wall


def settings_render():  # type: ignore[no-untyped-def]
    from mgdata.sim.config import load_sim_config

    return load_sim_config().render


def test_distractors_stay_clear_of_everything_that_moves_in_every_frame(pair: tuple[Path, Path]) -> None:
    reader = DatasetReader(pair[1])
    model = mujoco.MjModel.from_binary_path("s.mjb", {"s.mjb": reader.scene_mjb(0)})
    boxes = reader.record(0).meta.variation["appearance"]["distractors"]
    assert boxes, "the recipe asks for 2-3 distractors"
    data = mujoco.MjData(model)
    moving = [g for g in range(model.ngeom) if (model.geom_contype[g] or model.geom_conaffinity[g])
              and model.body_weldid[model.geom_bodyid[g]] != 0]
    closest = np.inf
    for state in reader.episode(0).physics_state:  # every frame, not only those the draw looked at
        set_physics_state(model, data, state)
        for g in moving:
            for box in boxes:  # the distance between the geom's and the distractor's bounding spheres
                gap = np.linalg.norm(data.geom_xpos[g] - np.array(box["pos"])) - model.geom_rbound[g] \
                    - np.sqrt(3.0) * box["size"]
                closest = min(closest, gap)
    assert closest > 0.0, closest
    for box in boxes:  # on the table top, resting on it
        assert -0.25 < box["pos"][0] < 1.05 and abs(box["pos"][1]) < 0.75 and box["pos"][2] == box["size"]


def test_render_appearance_k_draws_of_an_existing_dataset(pair: tuple[Path, Path], tmp_path: Path) -> None:
    plain, drawn = pair
    out = tmp_path / "x2"
    proc = subprocess.run([*MGDATA, "render", str(plain), "--out", str(out), "--appearance", "2"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert subprocess.run([*MGDATA, "validate", str(out)], capture_output=True, timeout=600).returncode == 0
    src, two, gen = DatasetReader(plain), DatasetReader(out), DatasetReader(drawn)
    assert two.num_episodes == 2 * src.num_episodes
    assert [two.record(i).meta.variation["appearance"]["k"] for i in range(2)] == [0, 1]
    for i in range(2):
        assert np.array_equal(two.episode(i).physics_state, src.episode(0).physics_state)
    # the shipped jar recipe has no [appearance]: render uses the defaults, so draw 0 differs from the
    # 2-3 distractors of the generated one only in its distractors; with the same settings it is the same
    assert two.record(0).meta.variation["appearance"]["surfaces"] == \
        gen.record(0).meta.variation["appearance"]["surfaces"]
    assert not np.array_equal(two.frames(0, "front"), two.frames(1, "front"))


def test_bad_appearance_input_is_one_error(pair: tuple[Path, Path], tmp_path: Path) -> None:
    for table, words in (({"hue": 2.0}, "hue"), ({"colour": 1}, "unknown key"), ({"table_kinds": ["marble"]},
                         "texture kinds"), ({"distractors": [0.5, 2]}, "whole numbers"),
                         ({"table_colors": [[1.2, 0.0, 0.0]]}, r"\[r, g, b\]"),
                         ({"wall_colors": []}, "non-empty")):
        with pytest.raises(RecipeError, match=words):
            parse_appearance(table, "jar.toml: [appearance]")
    assert AppearanceSettings().enabled is False  # off unless a recipe turns it on
    proc = subprocess.run([*MGDATA, "render", str(pair[0]), "--out", str(tmp_path / "bad"), "--appearance",
                           "-1"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 2 and "--appearance -1" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "bad").exists()
