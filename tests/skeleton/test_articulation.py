"""Driving an articulation by its handle: the drawer's slide, its handle grasps and the drive's segments."""

from __future__ import annotations

import numpy as np

from mgdata.skeleton.articulation import Drawer, HandleDrive
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import backed_off
from mgdata.skeleton.whatif import live_what_if

DRAWER = Drawer("cabinet")


def test_the_handle_moves_along_the_slide(ctx: Context) -> None:
    grasp = ctx.grasps["cabinet"][0]
    assert DRAWER.q(ctx) == 0.0
    closed = DRAWER.handle(ctx, grasp)
    opened = DRAWER.handle_at(ctx, grasp, 0.15)
    assert np.allclose(opened.pos - closed.pos, DRAWER.axis(ctx) * 0.15)
    assert np.allclose(opened.quat, closed.quat)
    with live_what_if(ctx, {"cabinet": 0.15}):  # the real drawer there: the handle grasp is where predicted
        assert np.allclose(DRAWER.handle(ctx, grasp).pos, opened.pos, atol=1e-9)
        assert np.allclose(DRAWER.handle_at(ctx, grasp, 0.0).pos, closed.pos, atol=1e-9)


def test_the_sweep_gap_is_zero_inside_and_shrinks_as_the_stroke_grows(ctx: Context) -> None:
    cab, geo = ctx.object_pose("cabinet"), ctx.scene.object_model("cabinet").geometry
    ahead = cab.pos[:2] + cab.rotation()[:2, 0] * (geo["front_x"] + 0.05)  # in front of the drawer
    assert DRAWER.sweep_gap(ctx, ahead, 0.2) == 0.0
    far = cab.pos[:2] + cab.rotation()[:2, 0] * (geo["front_x"] + 1.0)
    reach = geo["handle_pos"][0] + geo["handle_radius"]
    assert np.isclose(DRAWER.sweep_gap(ctx, far, 0.0), geo["front_x"] + 1.0 - reach)
    assert np.isclose(DRAWER.sweep_gap(ctx, far, 0.2), geo["front_x"] + 1.0 - reach - 0.2)


def test_the_opening_is_the_pulled_out_part(ctx: Context) -> None:
    geo = ctx.scene.object_model("cabinet").geometry
    with live_what_if(ctx, {"cabinet": 0.1}):
        opening = DRAWER.opening(ctx)
    assert np.isclose(opening.x[0], geo["front_x"] - 0.1) and opening.shift == 0.1
    assert np.isclose(opening.rim - opening.floor, geo["drawer_inner"][2])


def test_a_handle_drive_grasps_moves_releases_and_backs_off(ctx: Context) -> None:
    drive = HandleDrive(DRAWER, (("hand", "cabinet"),), moving=(("base", "cabinet/drawer"),))
    segs = drive.segments("open/", "pulled", open_steps=5, settle_steps=2, close_steps=6, speed=0.5)
    assert [g.name for g in segs] == ["open/open", "open/pre", "open/approach", "open/settle", "open/grip",
                                      "open/move", "open/release", "open/back"]
    assert segs[5].target == "pulled" and segs[5].speed == 0.5 and segs[5].gripper == "close"
    grasp = ctx.grasps["cabinet"][0]
    pre = drive.target(ctx, "handle_pre", grasp, standoff=0.1, retreat=0.05, ends={"pulled": 0.2})
    assert pre is not None and np.allclose(pre.pos, backed_off(DRAWER.handle(ctx, grasp), 0.1).pos)
    pulled = drive.target(ctx, "pulled", grasp, standoff=0.1, retreat=0.05, ends={"pulled": 0.2})
    assert pulled is not None and np.allclose(pulled.pos, DRAWER.handle_at(ctx, grasp, 0.2).pos)
    assert drive.target(ctx, "elsewhere", grasp, standoff=0.1, retreat=0.05, ends={}) is None
