"""Grasp choice from the gate's facts: the fact's grasps in its order, round-robin by the draw."""

from __future__ import annotations

import dataclasses

import pytest

from mgdata.episode.gate import AttemptFailed
from mgdata.skeleton.context import Context
from mgdata.skeleton.grasp_choice import choose_grasp, usable_grasps
from mgdata.skeleton.variation import Variation


def _with(ctx: Context, gate: dict, draw: int) -> Context:
    var = Variation(ctx.variation.seed, draw, ctx.variation.values, ctx.variation.planner_seed)
    return dataclasses.replace(ctx, task=dataclasses.replace(ctx.task, gate=gate), variation=var)


def test_the_gate_fact_names_the_grasps_and_the_draw_picks_round_robin(ctx: Context) -> None:
    grasps = ctx.grasps["target"]
    assert len(grasps) >= 2
    ids = (grasps[1].id, grasps[0].id, "not-in-the-db")
    asked: list[int] = []

    def now() -> tuple:  # the live check: not asked when the gate has the fact
        asked.append(1)
        return ()

    usable = usable_grasps(_with(ctx, {"grasps": ids}, 0), "target", "grasps", now)
    assert [g.id for g in usable] == [grasps[1].id, grasps[0].id]
    picks = [choose_grasp(_with(ctx, {"grasps": ids}, d), "target", "grasps", now, none="x").id
             for d in range(4)]
    assert picks == [grasps[1].id, grasps[0].id, grasps[1].id, grasps[0].id] and not asked


def test_without_the_fact_the_live_check_counts_and_none_fails_the_attempt(ctx: Context) -> None:
    live = ctx.grasps["target"][1:2]
    assert usable_grasps(_with(ctx, {}, 0), "target", "grasps", lambda: live) == tuple(live)
    with pytest.raises(AttemptFailed, match="nothing to hold") as err:
        choose_grasp(_with(ctx, {}, 0), "target", "grasps", lambda: (), none="nothing to hold")
    assert err.value.stage == "no_grasp"
