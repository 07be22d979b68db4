"""The destination pile (mgdata.skeleton.pile) on a stack base task: its spot, its segments, its targets."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PickAndCarry
from mgdata.skeleton.pile import Pile
from mgdata.skeleton.poses import held_object
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeleton.spots import clear_of, footprints, in_box
from mgdata.tasks.placer import footprint_radius
from tests.helpers.attempt_context import fresh_context

STACK = ("stack_0", "stack_1", "stack_2")
TOP = PickAndCarry("stack_2", grasp_filter=("top_down",), tag="s0/", support="stack_1")


@pytest.fixture(scope="module")
def stack_executor() -> Executor:
    recipe = load_family_recipe("stack")
    task = base_task(recipe, 3)  # a carton under three sponges
    assert tuple(o.name for o in task.objects if o.name.startswith("stack_")) == STACK
    return Executor(task, recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)


@pytest.fixture
def ctx(stack_executor: Executor) -> Context:
    return fresh_context(stack_executor, 0)


def test_the_spot_is_on_a_ring_beside_the_pack_in_the_region_clear_of_the_rest(ctx: Context) -> None:
    pile = Pile("target", STACK)
    xy = pile.spot(ctx, None)
    assert xy is not None and np.array_equal(xy, pile.spot(ctx, None))  # no draw: the first in ring order
    radius = {n: footprint_radius(ctx.task.object(n).model) for n in ("target", *STACK)}
    d = float(np.linalg.norm(xy - ctx.object_pose("target").pos[:2]))
    k = (d - max(radius.values()) - max(radius[n] for n in STACK) - ctx.param("pile_gap")) / ctx.param(
        "pile_ring_step")
    assert abs(k - round(k)) < 1e-9 and 0 <= round(k) < ctx.param("pile_rings")
    assert in_box(xy, ctx.param("pile_x"), ctx.param("pile_y"))
    rest = [o.name for o in ctx.task.objects if o.name not in ("target", *STACK)]
    assert clear_of(xy, max(radius[n] for n in STACK), footprints(ctx, rest), ctx.param("pile_gap"))


def test_an_object_goes_onto_the_pile_and_its_targets_are_over_and_on_it(ctx: Context) -> None:
    pile = Pile("target", STACK)
    pile.choose_spot(ctx, ctx.variation.rng("pile"))
    segs = pile.onto(ctx, TOP)
    assert [g.name for g in segs][-5:] == ["s0/lift", "s0/carry", "s0/place", "s0/release", "s0/retreat"]
    assert segs[-4].target == "s0/over_pile" and segs[-3].target == "s0/on_pile"
    assert pile.resolve("s0/grasp", ctx, TOP) is None
    over, on = pile.resolve("s0/over_pile", ctx, TOP), pile.resolve("s0/on_pile", ctx, TOP)
    assert over is not None and on is not None
    assert np.allclose(over.pos - on.pos, [0.0, 0.0, ctx.param("pile_approach")])
    put = on @ held_object(ctx, "stack_2").in_tcp  # where the TCP at on_pile puts the held object
    assert np.allclose(put.pos[:2], ctx.memo["pile_xy"]) and ctx.memo["piled"] == ["stack_2"]
