"""The pour's carrier outline, the wipe's and the pour's segments, and the opening's candidates (the full
motions run in the dusty and cabinet family tests)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mgdata.motion import Pose
from mgdata.sim.assets.library import get_model
from mgdata.skeleton.context import Context
from mgdata.skeleton.opening import Opening, into_opening
from mgdata.skeleton.pour import POUR_KEYS, POUR_KNOB, Pour, outline
from mgdata.skeleton.wipe import WIPE_KEYS, WIPE_KNOB


def test_a_round_carriers_outline_is_its_foot_and_rim_circles() -> None:
    bowl = get_model("bowl/round_00")
    pts = outline(bowl)
    geo = bowl.geometry
    assert pts.shape == (32, 3)
    assert np.allclose(np.hypot(pts[:16, 0], pts[:16, 1]), geo["bottom_radius"])
    assert np.allclose(pts[:16, 2], 0.0)
    assert np.allclose(np.hypot(pts[16:, 0], pts[16:, 1]), geo["rim_radius"])
    assert np.allclose(pts[16:, 2], geo["height"])


def test_a_boxs_outline_is_its_bounding_boxs_corners() -> None:
    model = dataclasses.replace(get_model("bowl/round_00"), geometry={})  # the bowl without its circles
    pts = outline(model)
    assert pts.shape == (8, 3)
    assert np.allclose(pts.min(axis=0), [-model.size[0] / 2, -model.size[1] / 2, 0.0])
    assert np.allclose(pts.max(axis=0), [model.size[0] / 2, model.size[1] / 2, model.size[2]])


class _Carrying:
    """A scene whose ``source`` is ``model`` (only the model: the segments read the carrier's shape)."""

    def __init__(self, scene: object, model: object) -> None:
        self._scene, self._model = scene, model

    def object_model(self, name: str) -> object:
        return self._model if name == "source" else self._scene.object_model(name)  # type: ignore[attr-defined]


@pytest.mark.parametrize("carrier", ["bowl/round_00", "tray/flat_03"])
def test_the_pour_tilts_straight_up_to_the_line_angle_then_in_joint_space(ctx: Context, carrier: str) -> None:
    """A bowl is carried in joint space, the food riding through the tilt; a tray is carried level in a
    straight line, and its tilt steps leave the food where it is (it slides inside the tray), letting only
    the tray pass through it."""
    params = {**ctx.params, "pour_steps": 4, "pour_line_deg": 60.0, "pour_speed": 0.5, "pour_hold_steps": 9}
    task = dataclasses.replace(ctx.task, params=params)
    var = dataclasses.replace(ctx.variation, values={**ctx.variation.values, POUR_KNOB.name: 100.0})
    pctx = dataclasses.replace(ctx, task=task, variation=var, scene=_Carrying(ctx.scene, get_model(carrier)))
    pour, flat = Pour("source", food="food", dest="dest"), carrier.startswith("tray/")
    segs = pour.segments(pctx)
    assert pour.flat(pctx) == flat
    assert pour.names(pctx) == ("pour_start", "pour_0", "pour_1", "pour_2", "pour_3")
    assert [(g.name, g.kind) for g in segs] == [
        ("carry", "linear" if flat else "free"), ("pour_0", "linear"), ("pour_1", "linear"),
        ("pour_2", "free"), ("pour_3", "free"), ("pour_settle", "hold")]
    assert all(g.attached == "source" for g in segs[:5]) and segs[-1].steps == 9
    assert segs[0].riders == ("food",) and segs[0].orientation == ("slerp" if flat else "hold")
    for g in segs[1:5]:
        assert (g.riders, g.allow.pairs) == (((), (("source", "food"),)) if flat else (("food",), ()))


def test_the_wipe_and_pour_keys_are_their_own() -> None:
    wipe, pour = {p.name for p in WIPE_KEYS.params}, {p.name for p in POUR_KEYS.params}
    assert not wipe & pour and "wipe_speed" in wipe and "pour_steps" in pour
    assert (WIPE_KNOB.name, POUR_KNOB.name) == ("wipe_press_dx", "pour_angle_deg")


def test_an_opening_too_short_for_the_object_has_no_candidate(ctx: Context) -> None:
    frame = Pose(np.array([0.5, 0.0, 0.8]), np.array([1.0, 0.0, 0.0, 0.0]))
    short = Opening(frame, (0.0, 0.01), 0.2, 0.0, 0.1)
    assert short.length == 0.01
    search = into_opening(ctx, "target", short, yaws=(0.0, 90.0), dy=0.0, drop=0.005, clear=0.02,
                          rng=np.random.default_rng(0), touch="cabinet")
    assert search.found is None and search.first is None and search.failure is None
