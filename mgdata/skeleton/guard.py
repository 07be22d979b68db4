"""How a guarded segment stops (:func:`touch`, :func:`force`) and its options (:class:`Guard`); the move
itself runs in :class:`mgdata.engine.guarded.GuardedMove`.

Example::

    until = force("lid", 5.0)   # stop once the hand presses on the lid with >= 5 N
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np


@dataclass(frozen=True)
class Until:
    """The stop condition of a guarded move: ``touch`` (any contact) or ``force`` (normal force ≥ ``newtons``)
    between the moving set and ``body`` (an object instance, ``table``, ``floor`` or a body such as
    ``jar/lid``). Build it with :func:`touch` or :func:`force`."""

    body: str
    kind: Literal["touch", "force"]
    newtons: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("touch", "force"):
            raise ValueError(f"until: kind must be 'touch' or 'force', got {self.kind!r}")
        if self.kind == "force" and not (np.isfinite(self.newtons) and self.newtons > 0):
            raise ValueError(f"until=force({self.body!r}, ...): the threshold must be > 0 N, "
                             f"got {self.newtons}")

    def met(self, touching: bool, newtons: float) -> bool:
        return touching if self.kind == "touch" else newtons >= self.newtons


def touch(body: str) -> Until:
    """Stop at the first contact with ``body``."""
    return Until(body, "touch")


def force(body: str, newtons: float) -> Until:
    """Stop once the contact with ``body`` presses with a normal force of at least ``newtons`` (N)."""
    return Until(body, "force", float(newtons))


@dataclass(frozen=True)
class Guard:
    """The options of a guarded segment (see :func:`mgdata.skeleton.segment.guarded`).

    Attributes:
        until: the stop condition.
        direction: world direction of travel (normalised here), or ``None`` to move towards the target.
        max_distance: travel limit (m); ``None`` only with a target (then: the distance to it).
        max_force: bound on the contact force (N); a ``force`` threshold must be below it.
        on_miss: ``"fail"`` (the attempt fails with ``guarded_no_contact``/``guarded_stalled``) or
            ``"continue"`` (the segment just ends; the outcome says so).
        press: sliding only: the world direction (normalised here) along which the contact force with
            ``until``'s body is regulated while travelling along ``direction``.
    """

    until: Until
    direction: tuple[float, float, float] | None
    max_distance: float | None
    max_force: float
    on_miss: Literal["fail", "continue"] = "fail"
    press: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.direction is not None:
            d = np.asarray(self.direction, dtype=np.float64)
            norm = float(np.linalg.norm(d)) if d.shape == (3,) else 0.0
            if not (np.isfinite(norm) and norm > 1e-9):
                raise ValueError(f"guarded: direction must be 3 finite numbers, not all 0, "
                                 f"got {self.direction}")
            object.__setattr__(self, "direction", tuple(float(x) for x in d / norm))
            if self.max_distance is None:
                raise ValueError("guarded: a move along a direction needs max_distance")
        if self.max_distance is not None and not (np.isfinite(self.max_distance) and self.max_distance > 0):
            raise ValueError(f"guarded: max_distance must be > 0 m, got {self.max_distance}")
        if not (np.isfinite(self.max_force) and self.max_force > 0):
            raise ValueError(f"guarded: max_force must be > 0 N, got {self.max_force}")
        if self.until.kind == "force" and self.until.newtons >= self.max_force:
            raise ValueError(f"guarded: the force threshold ({self.until.newtons} N) must be below max_force "
                             f"({self.max_force} N)")
        if self.on_miss not in ("fail", "continue"):
            raise ValueError(f"guarded: on_miss must be 'fail' or 'continue', got {self.on_miss!r}")
        if self.press is not None:
            p = np.asarray(self.press, dtype=np.float64)
            norm = float(np.linalg.norm(p)) if p.shape == (3,) else 0.0
            if not (np.isfinite(norm) and norm > 1e-9):
                raise ValueError(f"guarded: press must be 3 finite numbers, not all 0, got {self.press}")
            if self.until.kind != "force":
                raise ValueError("guarded: a sliding move (press) needs until=force(...)")
            object.__setattr__(self, "press", tuple(float(x) for x in p / norm))
