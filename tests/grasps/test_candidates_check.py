"""Grasp candidates from geometry, and the in-simulation check on real MuJoCo."""

from __future__ import annotations

import numpy as np

from mgdata.grasps.candidates import MAX_OPENING, CandidateConfig, candidates
from mgdata.grasps.check import GraspCheckConfig, check_grasp
from mgdata.grasps.db import Grasp
from mgdata.sim.assets import get_model, model_names


def test_side_grasps_point_at_the_axis_with_horizontal_fingers() -> None:
    cfg = CandidateConfig()
    model = get_model("jar/hinged_03")
    grasps = candidates(model, cfg)
    assert len(grasps) == 2 * cfg.angles and len({g.id for g in grasps}) == len(grasps)
    height = model.geometry["height"]
    for g in grasps:
        m = g.matrix()
        approach, closing, pos = m[:3, 2], m[:3, 1], m[:3, 3]
        assert g.approach == "side" and g.source == "generated" and g.status == "unvalidated"
        assert abs(approach[2]) < 1e-9 and abs(closing[2]) < 1e-9  # horizontal approach and fingers
        assert abs(np.dot(approach, closing)) < 1e-9
        radial = pos[:2]
        assert np.linalg.norm(radial) < 0.01 and np.dot(radial, approach[:2]) <= 1e-9  # on or behind the axis
        assert cfg.min_side_height - 1e-9 <= pos[2] <= height - cfg.side_top_clearance + 1e-9
    # articulated jar: no top grasps through the lid
    assert not any(g.approach == "top_down" for g in grasps)


def test_top_grasps_only_for_narrow_objects() -> None:
    cfg = CandidateConfig()
    for name in model_names("box")[:4]:
        model = get_model(name)
        tops = [g for g in candidates(model, cfg) if g.approach == "top_down"]
        narrow = min(model.size[:2]) + cfg.top_clearance <= MAX_OPENING
        assert bool(tops) == narrow
        for g in tops:
            assert np.allclose(g.matrix()[:3, 2], [0, 0, -1])


def test_check_accepts_a_good_grasp_and_rejects_a_bad_one() -> None:
    model = "jar/hinged_00"
    good = next(g for g in candidates(get_model(model), CandidateConfig()) if g.id == "side_180_r1")
    status, detail = check_grasp(model, good, GraspCheckConfig())
    assert status == "valid", detail
    assert "lifted" in detail
    # the same pose 8 cm higher, above the jar, closes on air
    high = Grasp("too_high", (good.pos[0], good.pos[1], good.pos[2] + 0.08), good.quat, "side", "annotated")
    status, detail = check_grasp(model, high, GraspCheckConfig())
    assert status == "invalid" and "fingers touch: False" in detail


def test_drawer_check_pulls_the_drawer_open_and_rejects_a_grasp_beside_the_handle() -> None:
    model = "cabinet/drawer_01"
    good = candidates(get_model(model), CandidateConfig())[1]
    assert good.frame == "drawer"
    status, detail = check_grasp(model, good, GraspCheckConfig())
    assert status == "valid", detail
    opened = float(detail.split("opened ")[1].split(" of")[0])
    assert opened >= 0.8 * GraspCheckConfig().pull * 100
    # 6 cm beside the bar, fingers closing on air: the pull leaves the drawer where it was
    beside = Grasp("beside", (good.pos[0], good.pos[1], good.pos[2] + 0.06), good.quat, "side", "annotated",
                   frame="drawer")
    status, detail = check_grasp(model, beside, GraspCheckConfig())
    assert status == "invalid" and "fingers touch: False" in detail, detail


def test_rim_pinch_lifts_a_tub_level() -> None:
    model = "container/tub_03"
    pinch = next(g for g in candidates(get_model(model), CandidateConfig()) if g.id == "rim_px_r1")
    status, detail = check_grasp(model, pinch, GraspCheckConfig())
    assert status == "valid", detail
    assert check_grasp(model, pinch, GraspCheckConfig()) == (status, detail)  # deterministic
