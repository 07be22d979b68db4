"""Task-seeded random streams by name: the streams the checks drew before keep their seeds."""

from __future__ import annotations

import numpy as np

from mgdata.skeleton.context import Context
from mgdata.skeleton.task_rng import SALTS, stream_word, task_rng


def test_named_streams_reproduce_the_old_hard_coded_salts() -> None:
    old = {"grasp_reach": 0x9A5, "handle_reach": 0xCAB, "arm_path_later": 0x5B07, "target_at_spot": 0x5B08,
           "pile_reach_down": 0x9171}
    assert dict(SALTS) == old
    for name, salt in old.items():
        a = task_rng(1234, name).random(4)
        b = np.random.default_rng(np.random.SeedSequence([1234, salt])).random(4)
        assert np.array_equal(a, b)


def test_other_names_get_their_own_stream_and_tasks_differ() -> None:
    assert stream_word("spot_check") not in SALTS.values()
    assert not np.array_equal(task_rng(1, "spot_check").random(3), task_rng(1, "other").random(3))
    assert not np.array_equal(task_rng(1, "grasp_reach").random(3), task_rng(2, "grasp_reach").random(3))
    assert np.array_equal(task_rng(5, "spot_check").random(3), task_rng(5, "spot_check").random(3))


def test_the_context_draws_by_its_tasks_seed(ctx: Context) -> None:
    assert np.array_equal(ctx.task_rng("handle_reach").random(3),
                          task_rng(ctx.task.seed, "handle_reach").random(3))
