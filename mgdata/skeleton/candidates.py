"""The first reachable candidate: try poses (or plans) in order of preference and keep the first the arm
reaches.

``reach`` solves one candidate (IK, a line …) and raises :class:`~mgdata.motion.MotionFailure` if it cannot;
candidates are produced lazily, so a later one is not even computed once one is reached. The solution (e.g.
the IK configuration) can seed the executor's IK for a runtime target (``ctx.q_hints``), so the executed
motion takes the branch that was checked.

Example::

    search = first_reachable(poses, lambda pose: ctx.planner.ik(pose, ctx.q_cmd, rng, collision_free=True))
    if search.found is None:
        raise AttemptFailed("target_fail", f"none reachable ({search.failure})")
    search.seed(ctx, "wipe_above")          # ctx.q_hints["wipe_above"] = the IK solution
    return search.found
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, TypeVar

import numpy as np

from mgdata.motion import MotionFailure

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class Search(Generic[T, R]):
    """What :func:`first_reachable` found.

    Attributes:
        found: the first candidate reached, or None.
        solution: what ``reach`` returned for it (None if none was reached).
        first: the first candidate tried (a fallback when none is reached), None if there were none.
        failure: the last :class:`MotionFailure` raised, None if none was.
    """

    found: T | None
    solution: R | None
    first: T | None
    failure: MotionFailure | None

    def seed(self, ctx: Context, target: str) -> None:
        """Seed the IK of runtime target ``target`` with the solution (an arm configuration)."""
        if isinstance(self.solution, np.ndarray):
            ctx.q_hints[target] = self.solution

    @property
    def found_or_first(self) -> T:
        """The candidate reached, else the first one (the executor then fails on it with its own reason);
        ValueError if there were no candidates."""
        if self.found is not None:
            return self.found
        if self.first is None:
            raise ValueError("first_reachable() had no candidates")
        return self.first


def first_reachable(candidates: Iterable[T], reach: Callable[[T], R]) -> Search[T, R]:
    """The first of ``candidates`` for which ``reach`` does not raise :class:`MotionFailure`.

    >>> def reach(x):
    ...     if x < 2:
    ...         raise MotionFailure("ik", f"{x} is too small")
    ...     return x * 10
    >>> s = first_reachable([0, 1, 2, 3], reach)
    >>> s.found, s.solution, s.first
    (2, 20, 0)
    """
    first: T | None = None
    failure: MotionFailure | None = None
    for i, candidate in enumerate(candidates):
        if i == 0:
            first = candidate
        try:
            solution = reach(candidate)
        except MotionFailure as err:
            failure = err
            continue
        return Search(candidate, solution, first, failure)
    return Search(None, None, first, failure)
