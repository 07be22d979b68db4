"""The first reachable candidate: lazily, the first that solves, its solution seeding the executor's IK."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.motion import MotionFailure, Pose
from mgdata.skeleton.candidates import first_reachable
from mgdata.skeleton.context import Context
from mgdata.skeleton.poses import raised


def test_takes_the_first_that_solves_and_computes_no_later_one() -> None:
    made: list[int] = []

    def candidates():  # type: ignore[no-untyped-def]
        for i in range(5):
            made.append(i)
            yield i

    def reach(i: int) -> int:
        if i < 2:
            raise MotionFailure("ik", f"{i} out of reach")
        return i * 10

    search = first_reachable(candidates(), reach)
    assert (search.found, search.solution, search.first, search.found_or_first) == (2, 20, 0, 2)
    assert str(search.failure) and made == [0, 1, 2]


def test_none_reached_keeps_the_first_and_the_last_failure() -> None:
    def reach(i: int) -> int:
        raise MotionFailure("ik", f"no {i}")

    search = first_reachable([7, 8], reach)
    assert search.found is None and search.found_or_first == 7
    assert search.failure is not None and search.failure.reason == "no 8"
    with pytest.raises(ValueError):
        _ = first_reachable([], reach).found_or_first


def test_the_reached_ik_solution_seeds_the_target(ctx: Context) -> None:
    tcp = ctx.commanded_tcp()
    far = Pose(tcp.pos + np.array([3.0, 0.0, 0.0]), tcp.quat)  # 3 m away: out of reach
    rng = np.random.default_rng(0)
    search = first_reachable([far, raised(tcp, 0.05)], lambda pose: ctx.planner.ik(pose, ctx.q_cmd, rng))
    assert search.found is not None and np.allclose(search.found.pos, tcp.pos + np.array([0.0, 0.0, 0.05]))
    search.seed(ctx, "up")
    assert np.allclose(ctx.planner.fk(ctx.q_hints["up"]).pos, search.found.pos, atol=1e-3)
