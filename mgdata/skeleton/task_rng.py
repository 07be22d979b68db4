"""Task-seeded random streams by name: the same for every attempt, worker and gate run of one task.

An attempt's own draws come from :meth:`mgdata.skeleton.variation.Variation.rng`. Checks that must agree
between the initial-state gate and every attempt of a task (which grasps are reachable, which spot is free)
use a stream seeded by the task's seed alone and a word for the purpose: a fixed salt for the streams in
:data:`SALTS` (the values they had when each check wrote its own, so data stays byte-identical), else the
first 8 bytes of the name's SHA-256.

Example::

    rng = ctx.task_rng("grasp_reach")     # == task_rng(ctx.task.seed, "grasp_reach")
"""

from __future__ import annotations

import hashlib
from types import MappingProxyType

import numpy as np

SALTS = MappingProxyType({
    "grasp_reach": 0x9A5,       # PickAndCarry.reachable_grasps
    "handle_reach": 0xCAB,      # cabinet: handle grasps reachable at both ends of the stroke
    "arm_path_later": 0x5B07,   # cabinet: the arm's path after a blocker is put down
    "target_at_spot": 0x5B08,   # cabinet: the target's grasp reachable at its put-down spot
    "pile_reach_down": 0x9171,  # stack: a straight-down hand reaches over a pile spot
})
"""Stream name -> its fixed salt."""


def stream_word(name: str) -> int:
    """The salt of stream ``name``: its :data:`SALTS` entry, else from the name's SHA-256.

    >>> stream_word("grasp_reach") == 0x9A5
    True
    """
    if name in SALTS:
        return SALTS[name]
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "little")


def task_rng(task_seed: int, name: str) -> np.random.Generator:
    """A generator for purpose ``name`` seeded by the task's seed alone.

    >>> float(task_rng(7, "pile_reach_down").random()) == float(
    ...     np.random.default_rng(np.random.SeedSequence([7, 0x9171])).random())
    True
    """
    return np.random.default_rng(np.random.SeedSequence([task_seed, stream_word(name)]))
