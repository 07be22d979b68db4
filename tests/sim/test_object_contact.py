"""recipes/sim.toml ``[contact]``: the stiff categories' geoms get their contact model, the finger pads' grip
contact stays what it was, bad values are one error naming the key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mgdata.errors import RecipeError
from mgdata.sim import robot
from mgdata.sim.config import load_sim_config, sim_config_from_dict
from mgdata.sim.scene import build_scene
from mgdata.sim.taskspec import ObjectPlacement
from tests.helpers.sim_tasks import task_with


def _mixed(m, g1: int, g2: int) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """MuJoCo's solref and solimp of a contact between geoms g1 and g2 (weighted by solmix)."""
    w1, w2 = m.geom_solmix[g1], m.geom_solmix[g2]
    mix = 0.5 if w1 + w2 == 0 else w1 / (w1 + w2)
    return (mix * m.geom_solref[g1] + (1 - mix) * m.geom_solref[g2],
            mix * m.geom_solimp[g1] + (1 - mix) * m.geom_solimp[g2])


def test_stiff_categories_get_the_contact_model_and_grip_is_unchanged() -> None:
    contact = load_sim_config().contact
    scene = build_scene(task_with(ObjectPlacement("food", "food/candy_03", (0.5, 0.2, 0.0)),
                                  ObjectPlacement("sponge", "sponge/block_02", (0.5, -0.2, 0.0)),
                                  ObjectPlacement("tray", "tray/flat_00", (0.5, 0.0, 0.0))))
    m = scene.model
    food, sponge, tray = (scene.object_geom_ids(n) for n in ("food", "sponge", "tray"))
    assert np.allclose(m.geom_solref[food], contact.stiff_solref)
    assert np.allclose(m.geom_solmix[food], contact.dominant_solmix)
    assert np.allclose(m.geom_solmix[sponge], contact.stiff_solmix)
    assert np.allclose(m.geom_solref[tray], [0.02, 1.0])  # not a stiff category
    assert np.allclose(m.geom_solmix[tray], 1.0)
    pad = next(g for g in range(m.ngeom) if m.body(m.geom_bodyid[g]).name in robot.FINGER_BODIES
               and m.geom_contype[g])
    pads = load_sim_config().gripper
    for obj in (food[0], sponge[0]):  # the pads grip a sponge (and must never touch the food)
        solref, solimp = _mixed(m, pad, obj)
        assert np.allclose(solref, pads.finger_solref, rtol=0, atol=1e-12)
        assert np.allclose(solimp[:3], pads.finger_solimp, rtol=0, atol=1e-12)
    assert _mixed(m, food[0], tray[0])[0][0] < 1.05 * contact.stiff_solref[0]  # the candy's solref wins


@pytest.mark.parametrize(("text", "message"), [
    ('[contact]\nstiff_categories = ["candy"]\n', r"\[contact\] stiff_categories names \['candy'\]"),
    ('[contact]\nstiff_categories = "food"\n', r"stiff_categories = 'food': expected a list of strings"),
    ('[contact]\ndominant_categories = ["tray"]\n', r"dominant_categories names \['tray'\], which"),
    ("[contact]\nstiff_solref = [0.0, 1.0]\n", r"\[contact\] stiff_solref = \[0.0, 1.0\]: expected"),
    ("[contact]\nstiff_solmix = 0\n", r"\[contact\] stiff_solmix = 0.0: expected a number > 0"),
])
def test_bad_contact_values_are_one_error_naming_file_and_key(tmp_path: Path, text: str,
                                                               message: str) -> None:
    path = tmp_path / "sim.toml"
    path.write_text(text)
    with pytest.raises(RecipeError, match=message) as err:
        load_sim_config(path)
    assert str(path) in str(err.value)


def test_no_stiff_category_keeps_mujocos_default_contact() -> None:
    sim = sim_config_from_dict({"contact": {"stiff_categories": [], "dominant_categories": []}})
    scene = build_scene(task_with(ObjectPlacement("food", "food/candy_03", (0.5, 0.2, 0.0))), sim=sim)
    food = scene.object_geom_ids("food")
    assert np.allclose(scene.model.geom_solref[food], [0.02, 1.0])
    assert np.allclose(scene.model.geom_solmix[food], 1.0)
