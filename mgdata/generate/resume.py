"""The draw cursor: which (task, draw index) to attempt next, so resumed runs continue without reuse.

Attempts are scheduled in one canonical order that does not depend on outcomes: repeatedly take the task
whose next draw is smallest (ties broken by the task's position in the selection). A run that is stopped and
resumed therefore attempts exactly what an uninterrupted run would have, and parallel workers can run ahead
of the commit point. The cursor is saved next to the dataset after every committed attempt; on resume it is
floored by the draw indices already in the dataset (an attempt committed just before a crash).

Example::

    cursor = DrawCursor.resume(tasks=(0, 1, 2), saved=RunState.load(path), seen=[(0, 4), (1, 3)])
    task, draw = cursor.take()
"""

from __future__ import annotations

import json
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mgdata.atomic import write_text_atomic
from mgdata.errors import DatasetError


@dataclass
class DrawCursor:
    """Next draw index per task, for the tasks selected in this run (in selection order)."""

    tasks: tuple[int, ...]
    next_draw: dict[int, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.tasks:
            raise ValueError("DrawCursor needs at least one task")
        if len(set(self.tasks)) != len(self.tasks):
            raise ValueError(f"duplicate task ids in {self.tasks}")
        for t in self.tasks:
            self.next_draw.setdefault(t, 0)

    def peek(self, skip: Collection[int] = ()) -> tuple[int, int] | None:
        """The next (task, draw) without consuming it, passing over the tasks in ``skip`` (``None``: every
        task is skipped)."""
        open_ = [i for i in range(len(self.tasks)) if self.tasks[i] not in skip]
        if not open_:
            return None
        pos = min(open_, key=lambda i: (self.next_draw[self.tasks[i]], i))
        task = self.tasks[pos]
        return task, self.next_draw[task]

    def take(self, skip: Collection[int] = ()) -> tuple[int, int] | None:
        """Consume and return the next (task, draw), passing over the tasks in ``skip`` (tasks whose
        ``--per-task`` quota is met); ``None`` when every task is skipped."""
        nxt = self.peek(skip)
        if nxt is not None:
            self.next_draw[nxt[0]] = nxt[1] + 1
        return nxt

    @classmethod
    def resume(
        cls,
        tasks: Iterable[int],
        saved: Mapping[int, int] | None = None,
        seen: Iterable[tuple[int, int]] = (),
    ) -> DrawCursor:
        """A cursor past every saved cursor position and every (task, draw) already in a dataset."""
        tasks = tuple(tasks)
        nxt = {t: int((saved or {}).get(t, 0)) for t in tasks}
        for task, draw in seen:
            if task in nxt:
                nxt[task] = max(nxt[task], int(draw) + 1)
        return cls(tasks, nxt)


@dataclass
class RunState:
    """What a dataset's generator must agree on to resume it, plus the per-task draw cursor.

    Attributes:
        family: family name; a resume with another family is refused.
        seed: the user seed (``--seed``); a resume with another seed is refused (seeds would collide).
        inputs_digest: hash of every input that shapes the data (recipe, spec, sim, motion, grasps); a run
            with other inputs is refused.
        next_draw: task id -> next draw index (covers every task ever attempted into this dataset).
        attempts: attempts committed into this dataset so far, over all runs (kept or not).
    """

    family: str
    seed: int
    inputs_digest: str
    next_draw: dict[int, int] = field(default_factory=dict)
    attempts: int = 0

    def check_compatible(self, other: RunState, path: Path) -> None:
        """Raise :class:`DatasetError` if ``other`` (this run's settings) cannot continue this dataset."""
        for name in ("family", "seed", "inputs_digest"):
            mine, theirs = getattr(self, name), getattr(other, name)
            if mine != theirs:
                raise DatasetError(
                    f"{path}: this dataset was generated with {name}={mine!r} but this run has "
                    f"{name}={theirs!r}; use the same settings to resume, or a new --out"
                )

    def to_json(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "seed": self.seed,
            "inputs_digest": self.inputs_digest,
            "next_draw": {str(k): v for k, v in sorted(self.next_draw.items())},
            "attempts": self.attempts,
        }

    @classmethod
    def load(cls, path: Path) -> RunState | None:
        """The saved state, or ``None`` if the file does not exist."""
        path = Path(path)
        if not path.exists():
            return None
        try:
            raw = json.loads(path.read_text(encoding="utf-8"))
            return cls(
                family=str(raw["family"]),
                seed=int(raw["seed"]),
                inputs_digest=str(raw["inputs_digest"]),
                next_draw={int(k): int(v) for k, v in raw["next_draw"].items()},
                attempts=int(raw.get("attempts", 0)),
            )
        except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError) as err:
            raise DatasetError(f"{path}: unreadable generator state ({err}); delete it to rebuild it from "
                               "the dataset's episode table") from None

    def save(self, path: Path) -> None:
        """Write atomically (readers never see a partial file)."""
        write_text_atomic(Path(path), json.dumps(self.to_json(), indent=2) + "\n")
