"""Putting a held object down into a rectangular opening (a drawer pulled out, a bin): over it with its
bottom clear of the rim, then straight down to just above the floor.

The opening is a rectangle in the xy plane of a ``frame`` (the cabinet's pose): ``x`` = (lo, hi) measured in
that frame shifted ``shift`` m along its x (a drawer's own frame, pulled out by ``shift``), ``|y| <=
half_y``; ``floor`` and ``rim`` are heights above the frame's origin.

Example::

    opening = Opening(cab_pose, (front_x - q, inner_x), inner_y, floor_z, floor_z + depth, shift=q)
    search = into_opening(ctx, "target", opening, yaws=(0.0, 90.0), dy=0.0, drop=0.01, clear=0.03, rng=rng)
    above, down = search.found                 # TCP poses (None: search.failure says why)
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mgdata.motion import AllowedContacts, Pose
from mgdata.skeleton.candidates import Search, first_reachable
from mgdata.skeleton.poses import about_z, held_object, upright

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context

OUTWARD_MIN_SLACK = 0.005
"""m of slack the opening must leave for the outer-end candidate to differ from the centred one."""


@dataclass(frozen=True)
class Opening:
    """A rectangular opening (see the module docstring)."""

    frame: Pose
    x: tuple[float, float]
    half_y: float
    floor: float
    rim: float
    shift: float = 0.0

    @property
    def length(self) -> float:
        """Its extent (m) along x."""
        return self.x[1] - self.x[0]

    def describe(self) -> str:
        """Its size, for messages."""
        return f"the opening is {self.length * 100:.1f} cm"


def into_opening(ctx: Context, obj: str, opening: Opening, *, yaws: Sequence[float], dy: float, drop: float,
                 clear: float, rng: np.random.Generator, touch: str) -> Search[tuple[Pose, Pose], object]:
    """TCP poses (above, down) putting the held ``obj`` into ``opening``: upright, turned about the vertical
    by each of ``yaws`` (deg) in turn, its footprint (from its bounding box) centred in the opening, else
    at its outer end (the wrist then keeps farther from what is behind it); ``dy`` m along y (clamped
    inside); bottom ``drop`` m above the floor, and ``clear`` m above the rim over it. The first whose pose
    above is reachable collision-free and whose line down solves (``obj`` may touch ``touch``) is found."""
    rot = opening.frame.rotation()
    size = np.asarray(ctx.scene.object_model(obj).size)
    held = held_object(ctx, obj)
    base = Pose(np.zeros(3), upright(ctx.object_pose(obj).quat))
    (lo_x, hi_x), margin = opening.x, drop

    def candidates() -> Iterator[tuple[Pose, Pose]]:
        for outward, yaw in itertools.product((False, True), yaws):
            turned = (Pose(np.zeros(3), about_z(math.radians(yaw))) @ base).quat
            r_local = rot.T @ Pose(np.zeros(3), turned).rotation()  # object axes in the frame
            half_x = float(np.abs(r_local[0, :2]) @ (size[:2] / 2))
            half_y = float(np.abs(r_local[1, :2]) @ (size[:2] / 2))
            slack = 0.5 * (hi_x - lo_x) - half_x - margin
            if slack < 0.0 or (outward and slack < OUTWARD_MIN_SLACK):
                continue
            cx = 0.5 * (lo_x + hi_x) + (slack if outward else 0.0) + opening.shift
            hy = opening.half_y
            cy = float(np.clip(dy, -hy + half_y + margin, hy - half_y - margin))
            origin = opening.frame.pos
            centre = origin + rot @ np.array([cx, cy, 0.0])
            low = Pose(np.array([centre[0], centre[1], origin[2] + opening.floor + margin]), turned)
            high = Pose(low.pos + np.array([0.0, 0.0, opening.rim + clear - opening.floor - margin]), turned)
            yield held.tcp_for(high), held.tcp_for(low)

    def reach(poses: tuple[Pose, Pose]) -> object:
        q_above = ctx.planner.ik(poses[0], ctx.q_cmd, rng, collision_free=True, attached=held.attachment)
        return ctx.planner.line(q_above, poses[1], rng, allowed=AllowedContacts(((obj, touch),)),
                                attached=held.attachment)

    return first_reachable(candidates(), reach)
