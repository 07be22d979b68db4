"""Each candidate generator on a real model of its category, judged from outside with raw MuJoCo: rays
between the two fingertip positions (computed here from the TCP pose) must cross the object where the
grasp means to squeeze it. And a drawer-handle grasp moves with the drawer."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.grasps.candidates import MAX_OPENING, CandidateConfig, candidates
from mgdata.grasps.check import GraspCheckConfig, check_placement
from mgdata.grasps.db import Grasp
from mgdata.grasps.edge import needs_overhang
from mgdata.sim.assets import get_model, model_names
from mgdata.sim.config import default_image_size
from mgdata.sim.robot import FINGERTIP_REACH
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement, TaskSpec
from mgdata.spec import SafetySpec

COLLIDING_GROUPS = np.array([1, 0, 0, 1, 0, 0], dtype=np.uint8)  # group 0 (both) and 3 (collision)


def _scene(model: str, grasp: Grasp) -> Scene:
    """The object where the grasp check stands it (an edge pinch's: pushed out over the table's edge)."""
    cfg = GraspCheckConfig()
    pos, yaw = check_placement(grasp, cfg, model)
    if needs_overhang(grasp):
        pos = (pos[0] - cfg.slide, pos[1], pos[2])
    task = TaskSpec(family="t", task_id=0, condition="base", prompt="", seed=0,
                    objects=(ObjectPlacement("object", model, pos, yaw),), safety=SafetySpec("t", (), ()),
                    image_size=default_image_size())
    return build_scene(task)


def _hit(scene: Scene, start: np.ndarray, direction: np.ndarray) -> float:
    """Distance (m) along a unit ray to the first colliding object geom, inf if none."""
    geom = np.array([-1], dtype=np.int32)
    dist = mujoco.mj_ray(scene.model, scene.data, start, direction, COLLIDING_GROUPS, 1, -1, geom)
    if geom[0] < 0 or geom[0] not in set(scene.object_geom_ids("object").tolist()):
        return np.inf
    return dist


def _fingertip_gap(scene: Scene, grasp: Grasp) -> tuple[float, float]:
    """(material between the open fingertips along the closing line, free gap from each fingertip to it):
    rays from each open fingertip towards the other, along two lines 4 mm either side of the pads' centre
    (the pads are 17 mm wide), the line that crosses most material counts."""
    world = grasp.world_matrix(scene.model, scene.data, "object")
    tcp, across, closing = world[:3, 3], world[:3, 0], world[:3, 1]
    best = (-np.inf, 0.0)
    for offset in (-0.004, 0.004):
        centre = tcp + across * offset
        left, right = centre + closing * MAX_OPENING / 2, centre - closing * MAX_OPENING / 2
        a, b = _hit(scene, left, -closing), _hit(scene, right, closing)
        assert a < MAX_OPENING and b < MAX_OPENING, grasp.id  # each ray meets the object before the other tip
        best = max(best, (MAX_OPENING - a - b, min(a, b)))
    return best


@pytest.mark.parametrize("model", ["cup/tumbler_03", "bottle/round_02"])
def test_side_grasps_straddle_the_object_with_room_to_spare(model: str) -> None:
    cfg = CandidateConfig()
    sides = [g for g in candidates(get_model(model), cfg) if g.id.startswith("side_")]
    assert len(sides) == 2 * cfg.angles
    for g in sides[::5]:
        scene = _scene(model, g)
        width, free = _fingertip_gap(scene, g)
        assert 0.03 < width < MAX_OPENING - cfg.finger_clearance + 1e-3, (g.id, width)  # the object, narrower
        assert free > 0.003, g.id  # both fingertips start outside it


@pytest.mark.parametrize("model", ["bowl/round_05", "mug/handled_02", "teacup/flared_01",
                                   "container/tub_04", "tray/flat_02"])
def test_rim_pinches_straddle_the_wall(model: str) -> None:
    obj = get_model(model)
    rims = [g for g in candidates(obj, CandidateConfig()) if g.id.startswith("rim_")]
    assert rims and all(g.approach == "top_down" for g in rims)
    for g in rims[::3]:
        scene = _scene(model, g)
        wall, free = _fingertip_gap(scene, g)
        # the closing line crosses one wall only (fingers on opposite sides of it): material between the
        # fingertips, at most about a wall's thickness (less where the line passes the seam of two convex wall
        # pieces, up to ~1 cm where a flared wall is crossed obliquely)
        assert 1e-4 < wall < 2.5 * obj.geometry["wall"] + 0.004, (g.id, wall)
        assert free > 0.01, g.id
        tips = g.world_matrix(scene.model, scene.data, "object")[:3, 3] + \
            g.world_matrix(scene.model, scene.data, "object")[:3, 2] * FINGERTIP_REACH
        assert tips[2] > 0.0  # the fingertips stay above the table


def test_a_bowl_gets_vertical_pinches_and_pinches_along_its_sloping_wall() -> None:
    obj = get_model("bowl/round_05")
    found = candidates(obj, CandidateConfig())
    vertical = [g for g in found if g.id.startswith("rim_")]
    along = [g for g in found if g.id.startswith("wall_")]
    assert len(vertical) == len(along) == 16
    slope = obj.geometry["rim_slope"]
    for g in along:
        approach = g.matrix()[:3, 2]
        # leans inwards by the wall's slope: its horizontal part points at the bowl's axis
        assert np.degrees(np.arccos(-approach[2])) == pytest.approx(np.degrees(slope), abs=1e-6)
        assert approach[:2] @ np.asarray(g.pos[:2]) < 0
    assert all(g.matrix()[2, 2] == pytest.approx(-1.0) for g in vertical)


@pytest.mark.parametrize("model", ["tray/flat_00", "tray/flat_06"])
def test_rim_pinch_keeps_the_inner_fingertip_off_a_shallow_floor(model: str) -> None:
    # A tray's walls are 2-3 cm tall: rim_depth would put the inner fingertip on its floor, and the arm rests
    # ~5 mm below its command, so a fingertip 2 mm up pressed the floor and friction stopped the fingers
    # short of the wall (0 of 16 trays lifted). The floor's top, from the raw geom.
    cfg = CandidateConfig()
    rims = [g for g in candidates(get_model(model), cfg) if g.id.startswith("rim_")]
    assert len(rims) == 8
    for g in rims:
        scene = _scene(model, g)
        m, d = scene.model, scene.data
        floor = m.geom("object/bottom").id
        floor_top = d.geom_xpos[floor][2] + m.geom_size[floor][2]
        world = g.world_matrix(m, d, "object")
        tip = world[:3, 3] + world[:3, 2] * FINGERTIP_REACH
        assert tip[2] - floor_top == pytest.approx(cfg.floor_clearance, abs=1e-6), g.id


def test_handle_and_knob_and_top_grasps_close_on_something_narrow() -> None:
    for model, prefix in (("mug/handled_05", "handle_"), ("teacup/flared_04", "handle_"),
                          ("lid/tub_02", "knob_"), ("box/carton_01", "top_"), ("sponge/block_03", "top_")):
        found = [g for g in candidates(get_model(model), CandidateConfig()) if g.id.startswith(prefix)]
        assert found, model
        for g in found[::2]:  # one roll of each pose
            scene = _scene(model, g)
            width, free = _fingertip_gap(scene, g)
            # a handle's bar is 1 cm thick; knobs, boxes and sponges leave room to the open fingers
            assert 0.005 < width < MAX_OPENING - 0.01 and free > 0.003, (model, g.id, width, free)


@pytest.mark.parametrize("model", ["board/chopping_02", "board/chopping_05", "plate/flat_03",
                                   "plate/flat_10"])
def test_edge_pinches_close_across_a_boards_thickness_or_a_plates_rim(model: str) -> None:
    # A board lying flat and a plate (its rim slopes 71-78° from vertical) fit no other generator: their edge
    # is pinched where it overhangs a table edge, the lower finger under it. Raw geometry: the rays between
    # the open fingertips cross the board's thickness, or the rim's sheet once; the pads are edge_inset in
    # from the edge, and the fingers close along the rim's normal (not vertically) on a plate.
    cfg, obj = CandidateConfig(), get_model(model)
    found = candidates(obj, cfg)
    assert found and all(g.id.startswith("edge_") and needs_overhang(g) for g in found)
    assert len(found) == (8 if obj.category == "board" else 2 * cfg.rim_angles)
    for g in found[::2]:  # one roll of each pose
        scene = _scene(model, g)
        width, free = _fingertip_gap(scene, g)
        world = g.world_matrix(scene.model, scene.data, "object")
        closing, approach = world[:3, 1], world[:3, 2]
        if obj.category == "board":
            assert width == pytest.approx(obj.size[2], abs=2e-4) and free > 0.02, (g.id, width, free)
            assert abs(closing[2]) == pytest.approx(1.0, abs=1e-5) and abs(approach[2]) < 1e-3  # as it rests
        else:
            rise = np.pi / 2 - obj.geometry["rim_slope"]
            assert 1e-4 < width < 0.003 and free > 0.02, (g.id, width, free)  # the rim's ~1 mm sheet
            assert np.degrees(np.arccos(abs(closing[2]))) == pytest.approx(np.degrees(rise), abs=0.05)
        outward = -approach[:2] / np.linalg.norm(approach[:2])
        centre = np.asarray(scene.object_pose("object")[0][:2])
        edge = obj.geometry.get("rim_radius") or obj.geometry["half_extents"][0 if "x" in g.id else 1]
        assert (world[:2, 3] - centre) @ outward == pytest.approx(edge - cfg.edge_inset, abs=1e-4)


def test_only_edge_pinches_need_an_overhang() -> None:
    # the grasp check pushes an object over the table's edge for these alone
    cfg = CandidateConfig()
    for name in model_names():
        if name.split("/")[0] not in ("liquid", "dust", "food"):
            for g in candidates(get_model(name), cfg):
                assert needs_overhang(g) == g.id.startswith("edge_"), (name, g.id)


def test_drawer_handle_grasp_is_in_the_drawer_frame_and_moves_with_it() -> None:
    model = "cabinet/drawer_02"
    grasps = candidates(get_model(model), CandidateConfig())
    assert [g.id for g in grasps] == ["handle_r0", "handle_r1", "handle_p_r0", "handle_p_r1", "handle_n_r0",
                                      "handle_n_r1"] and all(g.frame == "drawer" for g in grasps)
    g = grasps[0]
    scene = _scene(model, g)
    m, d = scene.model, scene.data
    handle = m.geom("object/handle").id
    before = g.world_matrix(m, d, "object")
    # closed: TCP on the bar's axis, approach towards the cabinet (opposite the slide), fingers across the bar
    assert np.linalg.norm(before[:3, 3] - d.geom_xpos[handle]) < 1e-6
    bar_axis = d.geom_xmat[handle].reshape(3, 3)[:, 2]
    assert abs(before[:3, 1] @ bar_axis) < 1e-9 and abs(before[:3, 2] @ bar_axis) < 1e-9
    joint = m.joint("object/drawer_slide")
    slide = d.xmat[joint.bodyid[0]].reshape(3, 3) @ joint.axis
    assert before[:3, 2] @ slide < -0.99
    # open the drawer 12 cm in raw MuJoCo: the grasp's world pose follows the handle
    d.qpos[joint.qposadr[0]] = 0.12
    mujoco.mj_forward(m, d)
    after = g.world_matrix(m, d, "object")
    assert np.allclose(after[:3, 3] - before[:3, 3], 0.12 * slide, atol=1e-9)
    assert np.allclose(after[:3, 3], d.geom_xpos[handle], atol=1e-9)
    assert np.allclose(after[:3, :3], before[:3, :3], atol=1e-12)
    # the other poses: on the bar's axis, a quarter of the bar's length (raw geom size) off its middle
    half = m.geom_size[handle][1]
    offs = [g.world_matrix(m, d, "object")[:3, 3] - d.geom_xpos[handle] for g in (grasps[2], grasps[4])]
    for off in offs:
        assert abs(abs(off @ bar_axis) - 0.25 * 2.0 * half) < 1e-6
        assert np.linalg.norm(np.cross(off, bar_axis)) < 1e-6
    assert np.allclose(offs[0], -offs[1], atol=1e-9)  # one each way
