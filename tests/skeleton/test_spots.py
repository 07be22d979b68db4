"""Free spots: candidate points, the clearance test, and the choice of a spot to put something down."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.episode.gate import AttemptFailed
from mgdata.skeleton.context import Context
from mgdata.skeleton.spots import (
    Footprint,
    SpotRules,
    clear_of,
    footprint,
    footprints,
    free_spot,
    grid,
    in_box,
    ring,
    starting_at,
)
from mgdata.tasks.placer import footprint_radius


def test_grid_covers_the_box_with_both_ends() -> None:
    pts = grid((0.0, 0.2), (-0.1, 0.1), 0.1)
    assert len(pts) == 9 and np.allclose(pts[0], [0.0, -0.1]) and np.allclose(pts[-1], [0.2, 0.1])
    assert all(in_box(p, (0.0, 0.2), (-0.1, 0.1)) for p in pts)
    assert not in_box(np.array([0.21, 0.0]), (0.0, 0.2), (-0.1, 0.1))


def test_ring_points_are_evenly_spaced_at_the_distance() -> None:
    centre = np.array([0.5, -0.2])
    pts = ring(centre, 0.15, 6)
    assert np.allclose([np.linalg.norm(p - centre) for p in pts], 0.15)
    assert np.allclose([np.linalg.norm(pts[i] - pts[i - 1]) for i in range(6)], 0.15)  # hexagon side = radius


def test_clear_of_is_the_circle_gap() -> None:
    other = [Footprint(np.array([0.1, 0.0]), 0.03)]
    assert clear_of(np.zeros(2), 0.05, other, gap=0.02)       # 0.1 >= 0.05 + 0.03 + 0.02
    assert not clear_of(np.zeros(2), 0.05, other, gap=0.021)


def test_starting_at_wraps() -> None:
    assert starting_at([1, 2, 3], 4) == [2, 3, 1]


def test_footprints_are_where_the_objects_stand(ctx: Context) -> None:
    fp = footprint(ctx, "obstacle")
    assert np.allclose(fp.xy, ctx.scene.data.xpos[ctx.scene.model.body("obstacle").id][:2])
    assert fp.radius == footprint_radius(ctx.task.object("obstacle").model)
    assert [f.radius for f in footprints(ctx, ["target", "obstacle"])][1] == fp.radius


def _rules(region: tuple[float, ...], keep_out_margin: float = 0.0) -> SpotRules:
    return SpotRules(region, 0.02, 0.01, ("cabinet",), lambda xy: float(np.linalg.norm(xy)), keep_out_margin,
                     0.0, 0.005, 0.08, "in the test region")


def test_free_spot_says_which_check_found_nothing(ctx: Context) -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(AttemptFailed, match="no free spot for obstacle in the test region"):
        free_spot(ctx, "obstacle", _rules((0.3, 0.5, -0.3, -0.1), keep_out_margin=5.0), rng=rng,
                  accept=lambda at: True)
    seen = []
    with pytest.raises(AttemptFailed, match="no free spot for obstacle is reachable holding it"):
        free_spot(ctx, "obstacle", _rules((0.3, 0.5, -0.3, -0.1)), rng=rng,
                  accept=lambda at: seen.append(at) is not None)
    # every spot offered is upright on the table, farthest from the keep-out zone (here: the origin) first
    assert seen and all(np.allclose(p.rotation()[:, 2], [0.0, 0.0, 1.0]) for p in seen)
    dist = [float(np.linalg.norm(p.pos[:2])) for p in seen]
    assert dist[0] == max(dist)
