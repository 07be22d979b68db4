"""Per-attempt seeds and variation draws, derived only from (family, task, draw index, user seed).

Every random choice of an attempt (grasp, standoffs, lift height, jitter, planner seed) comes from one
:class:`Variation`, so an attempt is reproduced bit for bit from its recorded seed. Draw 0 of a task is the
*canonical* one: every knob at the middle of its range. Grasps are taken round-robin over the reachable ones.

Example::

    knobs = {"standoff_m": (0.08, 0.12), "lift_m": (0.10, 0.14)}
    var = draw_variation("jar", task_id=3, draw=7, base_seed=0, knobs=knobs)
    var.values["standoff_m"], var.planner_seed
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np


def attempt_seed(family: str, task_id: int, draw: int, base_seed: int = 0) -> int:
    """The 63-bit seed of one attempt: ``SeedSequence`` entropy from (family, task, draw, user seed)."""
    if task_id < 0 or draw < 0 or base_seed < 0:
        raise ValueError(f"task_id, draw and base_seed must be >= 0, got {task_id}, {draw}, {base_seed}")
    family_word = int.from_bytes(hashlib.sha256(family.encode()).digest()[:8], "little")
    state = np.random.SeedSequence([family_word, task_id, draw, base_seed]).generate_state(1, np.uint64)
    return int(state[0] >> np.uint64(1))


@dataclass(frozen=True)
class Variation:
    """The random choices of one attempt.

    Attributes:
        seed: the attempt seed (from :func:`attempt_seed`); stored in the episode metadata.
        draw: the draw index within the task.
        values: knob name -> drawn value (units as the recipe's ``[variation]`` table says).
        planner_seed: seed for the motion planner's own randomness (IK restarts, RRT sampling).
    """

    seed: int
    draw: int
    values: Mapping[str, float]
    planner_seed: int

    def __getitem__(self, name: str) -> float:
        try:
            return self.values[name]
        except KeyError:
            known = ", ".join(sorted(self.values)) or "none"
            raise KeyError(f"no variation knob {name!r} (the recipe's [variation] has: {known})") from None

    def rng(self, stream: str) -> np.random.Generator:
        """An independent generator for a named purpose (``"planner"``, ``"grasp"`` …) of this attempt."""
        word = int.from_bytes(hashlib.sha256(stream.encode()).digest()[:8], "little")
        return np.random.default_rng(np.random.SeedSequence([self.seed, word]))

    def pick(self, n: int) -> int:
        """Round-robin among ``n`` options (e.g. the reachable grasps): draw ``k`` takes ``k mod n``."""
        if n <= 0:
            raise ValueError("pick() needs at least one option")
        return self.draw % n

    def as_meta(self) -> dict[str, Any]:
        """Plain data for :class:`mgdata.record.episode.EpisodeMeta` ``variation``."""
        return {"draw": self.draw, "planner_seed": self.planner_seed, **dict(sorted(self.values.items()))}


def draw_variation(
    family: str,
    task_id: int,
    draw: int,
    base_seed: int,
    knobs: Mapping[str, tuple[float, float]],
) -> Variation:
    """Draw every knob uniformly in its ``(low, high)`` range (midpoints on draw 0), in sorted-name order."""
    seed = attempt_seed(family, task_id, draw, base_seed)
    rng = np.random.default_rng(seed)
    values: dict[str, float] = {}
    for name in sorted(knobs):
        low, high = knobs[name]
        values[name] = float(0.5 * (low + high)) if draw == 0 else float(rng.uniform(low, high))
    planner_seed = int(rng.integers(0, 2**31 - 1))
    return Variation(seed, draw, MappingProxyType(values), planner_seed)
