"""Driving an articulation by its handle: the drawer's slide, what is in its way, its handle grasps and the
drive's segments and arm path."""

from __future__ import annotations

import numpy as np

from mgdata.motion import AllowedContacts
from mgdata.sim.robot import ROOT_BODY
from mgdata.skeleton.articulation import Drawer, HandleDrive
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import backed_off
from mgdata.skeleton.whatif import live_what_if
from mgdata.tasks.placer import footprint_radius

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


def test_in_the_way_are_the_objects_whose_footprint_comes_within_margin_of_the_sweep(ctx: Context) -> None:
    names = ("obstacle", "target")
    gap = {n: DRAWER.sweep_gap(ctx, ctx.object_pose(n).pos[:2], 0.2)
           - footprint_radius(ctx.task.object(n).model) for n in names}
    assert DRAWER.in_the_way(ctx, names, stroke=0.2, margin=max(gap.values()) + 0.01) == list(names)
    assert DRAWER.in_the_way(ctx, names, stroke=0.2, margin=min(gap.values()) - 0.01) == []
    assert DRAWER.in_the_way(ctx, names[::-1], stroke=0.2, margin=1.0) == list(names[::-1])  # their order


def test_a_drives_arm_path_runs_through_pre_grasp_handle_moved_handle_and_back_off(ctx: Context) -> None:
    drive = HandleDrive(DRAWER, (("hand", "cabinet"),))
    by_id = {g.id: g for g in ctx.grasps["cabinet"]}
    grasp = by_id[ctx.task.gate["handle_grasps"][0]]  # one the gate found drivable
    loose = AllowedContacts(tuple((ROOT_BODY, o.name) for o in ctx.task.objects))
    path = drive.arm_path(ctx, grasp, by=0.15, standoff=0.08, rng=np.random.default_rng(0), allowed=loose)
    assert len(path) == 4 and path[0].shape == (1, 7)  # the pre-grasp's IK, then three straight lines
    handle, moved = DRAWER.handle(ctx, grasp), DRAWER.handle_moved(ctx, grasp, 0.15)
    ends = [ctx.planner.fk(part[-1]).pos for part in path]
    wanted = (backed_off(handle, 0.08), handle, moved, backed_off(moved, 0.08))
    assert all(np.allclose(end, want.pos, atol=1e-3) for end, want in zip(ends, wanted, strict=True))
