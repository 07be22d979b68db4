"""Free spots to set something down: candidate points (a grid over a region, a ring around a point) and the
test that a footprint there keeps clear of the others.

Footprints are circles in the table's plane (:func:`mgdata.tasks.placer.footprint_radius`).

Example::

    others = footprints(ctx, ["cup", "plate"])
    free = [xy for xy in grid((0.3, 0.6), (-0.4, -0.1), 0.02) if clear_of(xy, 0.04, others, gap=0.01)]
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.motion import AllowedContacts, MotionFailure, Pose
from mgdata.sim.robot import ROOT_BODY
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.skeleton.poses import backed_off, held_object, upright
from mgdata.tasks.placer import footprint_radius

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context

T = TypeVar("T")


@dataclass(frozen=True)
class Footprint:
    """A circle on the table: centre ``xy`` (world, m) and ``radius`` (m)."""

    xy: np.ndarray
    radius: float


def footprint(ctx: Context, name: str) -> Footprint:
    """The footprint of task object ``name`` where it stands now."""
    return Footprint(ctx.object_pose(name).pos[:2], footprint_radius(ctx.task.object(name).model))


def footprints(ctx: Context, names: Iterable[str]) -> list[Footprint]:
    """The footprints of the task objects ``names`` where they stand now."""
    return [footprint(ctx, n) for n in names]


def clear_of(xy: np.ndarray, radius: float, others: Iterable[Footprint], gap: float) -> bool:
    """Does a footprint of ``radius`` at ``xy`` keep ``gap`` from every one of ``others``?

    >>> clear_of(np.zeros(2), 0.05, [Footprint(np.array([0.2, 0.0]), 0.1)], gap=0.01)
    True
    """
    return all(np.linalg.norm(xy - o.xy) >= radius + o.radius + gap for o in others)


def in_box(xy: np.ndarray, x: Sequence[float], y: Sequence[float]) -> bool:
    """Is ``xy`` inside the box ``x`` = (x0, x1) × ``y`` = (y0, y1) (edges included)?"""
    return bool(x[0] <= xy[0] <= x[1] and y[0] <= xy[1] <= y[1])


def grid(x: Sequence[float], y: Sequence[float], step: float) -> list[np.ndarray]:
    """Points ``step`` apart over the box ``x`` × ``y`` (both ends included), x-major.

    >>> [p.tolist() for p in grid((0.0, 0.1), (0.0, 0.1), 0.1)]
    [[0.0, 0.0], [0.0, 0.1], [0.1, 0.0], [0.1, 0.1]]
    """
    return [np.array([px, py]) for px in np.arange(x[0], x[1] + 1e-9, step)
            for py in np.arange(y[0], y[1] + 1e-9, step)]


def ring(centre: np.ndarray, distance: float, n: int) -> list[np.ndarray]:
    """``n`` points ``distance`` from ``centre`` at evenly spaced bearings, the first along +x.

    >>> [p.round(6).tolist() for p in ring(np.zeros(2), 1.0, 4)][:2]
    [[1.0, 0.0], [0.0, 1.0]]
    """
    out = []
    for k in range(n):
        phi = 2.0 * math.pi * k / n
        out.append(centre + distance * np.array([math.cos(phi), math.sin(phi)]))
    return out


def starting_at(items: Sequence[T], start: int) -> list[T]:
    """``items`` in order from index ``start`` (mod their number), wrapping round.

    >>> starting_at("abcd", 6)
    ['c', 'd', 'a', 'b']
    """
    n = len(items)
    return [items[(start + i) % n] for i in range(n)]


def put_down(ctx: Context, obj: str, spots: Iterable[np.ndarray], *, drop: float, standoff: float,
             rng: np.random.Generator, accept: Callable[[Pose], bool],
             rise: float = 0.04) -> tuple[Pose, Pose] | None:
    """TCP poses above and at the first of ``spots`` where the held ``obj``, stood upright (its heading
    kept) ``drop`` m above the table, passes ``accept`` (its world pose there) and the arm can put it there
    as the executor plans it: a straight carry (orientation slerped) to above the spot (at the TCP's height
    now, at least ``rise`` m above the put-down), the line down (``obj`` may touch the table) and the
    retreat ``standoff`` m back along the approach (the object left out: the planner's copy is still in the
    hand). None if no spot passes."""
    held = held_object(ctx, obj)
    quat = Pose(np.zeros(3), upright(ctx.object_pose(obj).quat)).quat
    lift = ctx.commanded_tcp().pos[2]
    planner = ctx.planner
    for xy in spots:
        at = Pose(np.array([xy[0], xy[1], TABLE_TOP_Z + drop]), quat)
        if not accept(at):
            continue
        down = held.tcp_for(at)
        above = Pose(np.array([down.pos[0], down.pos[1], max(lift, down.pos[2] + rise)]), down.quat)
        try:
            carry = planner.line(ctx.q_cmd, above, rng, orientation="slerp", attached=held.attachment)
            put = planner.line(carry.q[-1], down, rng, allowed=AllowedContacts(((obj, "table"),)),
                               attached=held.attachment)
            planner.line(put.q[-1], backed_off(down, standoff), rng,
                         allowed=AllowedContacts(((ROOT_BODY, obj),)))
        except MotionFailure:
            continue
        return above, down
    return None


@dataclass(frozen=True)
class SpotRules:
    """Where an object moved out of the way may be put down.

    Attributes:
        region: x0, x1, y0, y1 (m, world) of the grid of candidate spots.
        spacing: m between grid points.
        clearance: m its footprint keeps from every other task object's (but those in ``ignore``).
        ignore: task objects not counted (e.g. the articulated one whose sweep is ``keep_out``).
        keep_out: distance (m) from a world xy to the zone kept free (0 inside it).
        keep_out_margin: m its footprint keeps from that zone.
        pick: which candidate is tried first, as a fraction through the farthest third (the draw).
        drop: m above the table it is released.
        standoff: m the hand backs off along its approach after releasing it.
        where: how the message of an empty grid names the region (``"in clear_region outside the sweep"``).
    """

    region: Sequence[float]
    spacing: float
    clearance: float
    ignore: tuple[str, ...]
    keep_out: Callable[[np.ndarray], float]
    keep_out_margin: float
    pick: float
    drop: float
    standoff: float
    where: str


def free_spot(ctx: Context, obj: str, rules: SpotRules, *, rng: np.random.Generator,
              accept: Callable[[Pose], bool]) -> tuple[Pose, Pose]:
    """TCP poses above and at a free spot for the held ``obj``: the grid points of ``rules.region`` whose
    footprint keeps clear of the other objects and of the keep-out zone, farthest from that zone first,
    starting ``rules.pick`` of the way through the farthest third; the first that ``accept`` takes and the
    arm can put it down at (:func:`put_down`). None found ends the attempt (``target_fail``)."""
    x0, x1, y0, y1 = rules.region
    radius = footprint_radius(ctx.task.object(obj).model)
    others = footprints(ctx, [o.name for o in ctx.task.objects if o.name not in (obj, *rules.ignore)])
    away = radius + rules.keep_out_margin
    spots = [p for p in grid((x0, x1), (y0, y1), rules.spacing)
             if clear_of(p, radius, others, rules.clearance) and not rules.keep_out(p) < away]
    if not spots:
        raise AttemptFailed("target_fail", f"no free spot for {obj} {rules.where}")
    spots.sort(key=lambda p: -rules.keep_out(p))
    start = int(rules.pick * max(1, len(spots) // 3)) % len(spots)
    found = put_down(ctx, obj, starting_at(spots, start), drop=rules.drop, standoff=rules.standoff, rng=rng,
                     accept=accept)
    if found is None:
        raise AttemptFailed("target_fail", f"no free spot for {obj} is reachable holding it")
    return found
