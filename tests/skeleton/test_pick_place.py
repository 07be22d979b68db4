"""The tagged pick and place segments, and the relocation built on them."""

from __future__ import annotations

from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PickAndCarry
from mgdata.skeleton.pick_place import PickPlace
from mgdata.skeleton.relocate import Relocate

PARAMS = {"open_steps": 7, "grasp_settle_steps": 3, "close_steps": 9}


def test_pick_and_place_segments_are_tagged_and_renamed() -> None:
    sponge = PickPlace("sponge", tag="sponge_", renamed={"pre_grasp": "pre", "grasp_settle": "settle"})
    pick = sponge.pick(PARAMS)
    assert [(g.name, g.kind) for g in pick] == [
        ("sponge_open", "gripper"), ("sponge_pre", "free"), ("sponge_approach", "linear"),
        ("sponge_settle", "hold"), ("sponge_close", "gripper"), ("sponge_lift", "linear")]
    assert [g.target for g in pick if g.target] == ["sponge_pre", "sponge_grasp", "sponge_lift"]
    assert pick[0].steps == 7 and pick[3].steps == 3 and pick[4].steps == 9
    assert pick[5].attached == "sponge" and ("sponge", "table") in pick[5].allow.pairs
    place = sponge.place("sponge_place", retreat_steps=4)
    assert [(g.name, g.target) for g in place] == [("sponge_place", "sponge_place"), ("sponge_release", None),
                                                   ("sponge_retreat", "sponge_retreat")]
    assert place[1].steps == 4 and place[0].gripper == "close" and place[2].gripper == "open"


def test_pick_and_carry_builds_the_same_segments(ctx: Context) -> None:
    carry = PickAndCarry("obstacle", riders=("food",), tag="o/", support="target")
    steps = PickPlace("obstacle", "o/", ("food",), "target")
    assert carry.pick_segments(ctx) == steps.pick(ctx.params)
    assert carry.place_segments("o/spot", retreat_steps=3) == steps.place("o/spot", retreat_steps=3)


def test_a_relocation_picks_carries_straight_and_puts_down(ctx: Context) -> None:
    segs = Relocate("obstacle").segments(ctx)
    names = [g.name for g in segs]
    assert names[:6] == ["obstacle/open", "obstacle/pre_grasp", "obstacle/approach", "obstacle/grasp_settle",
                         "obstacle/close", "obstacle/lift"]
    carry = segs[6]
    assert (carry.name, carry.kind, carry.target, carry.orientation) == ("obstacle/carry", "linear",
                                                                          "obstacle/over_spot", "slerp")
    assert names[7:] == ["obstacle/place", "obstacle/release", "obstacle/retreat"]
    assert segs[7].target == "obstacle/spot"
    spot = (ctx.tcp_pose(), ctx.commanded_tcp())
    assert Relocate("obstacle").resolve("obstacle/over_spot", ctx, lambda: spot) is spot[0]
    assert Relocate("obstacle").resolve("obstacle/spot", ctx, lambda: spot) is spot[1]
    assert Relocate("obstacle").resolve("target/spot", ctx, lambda: spot) is None
