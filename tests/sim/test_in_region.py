"""``in_region`` against the goal sphere: the box's centre (or its whole volume, or a volume fraction) inside
the sphere, never "the box touches it". References are computed from the box's collision geom in the compiled
model (``geom_xpos``, ``geom_xmat``, ``geom_size``), not from the predicate code."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.errors import SpecError
from mgdata.sim.labelling import Labeller
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import GoalRegion, ObjectPlacement
from mgdata.spec import Proposition, SafetySpec, proposition_from_mapping
from tests.helpers.sim_tasks import task_with

GOAL = np.array([0.5, 0.2, 0.15])
RADIUS = 0.05
MODES = {"centre": {}, "contained": {"mode": "contained"}, "f25": {"mode": "fraction", "min_fraction": 0.25},
         "f50": {"mode": "fraction", "min_fraction": 0.5}, "f75": {"mode": "fraction", "min_fraction": 0.75}}


def build(radius: float) -> tuple[Scene, Labeller]:
    """A carton (7.3 × 5.5 × 13.9 cm, one box geom) and a goal sphere of ``radius`` at ``GOAL``."""
    props = tuple(Proposition(name, "in_region", ("box",), params) for name, params in MODES.items())
    scene = build_scene(task_with(ObjectPlacement("box", "box/carton_03", (0.5, -0.2, 0.0)),
                                  spec=SafetySpec("t", (), props), goal=GoalRegion(tuple(GOAL), radius)))
    return scene, Labeller(scene, scene.task.safety)


@pytest.fixture(scope="module")
def goal5cm() -> tuple[Scene, Labeller]:
    return build(RADIUS)


@pytest.fixture(scope="module")
def goal20cm() -> tuple[Scene, Labeller]:
    return build(0.2)


UPRIGHT = np.array([1.0, 0.0, 0.0, 0.0])


def place(scene: Scene, pos: np.ndarray, quat: np.ndarray = UPRIGHT) -> None:
    """Put the box's frame (bottom centre) at ``pos`` with orientation ``quat`` (w, x, y, z); no stepping."""
    adr = scene.model.jnt_qposadr[scene.model.joint("box/free").id]
    scene.data.qpos[adr : adr + 3] = pos
    scene.data.qpos[adr + 3 : adr + 7] = quat / np.linalg.norm(quat)
    mujoco.mj_forward(scene.model, scene.data)


def box_geom(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World centre, rotation and half sizes of the carton's collision box."""
    g = scene.model.geom("box/body").id
    d = scene.data
    return d.geom_xpos[g].copy(), d.geom_xmat[g].reshape(3, 3).copy(), scene.model.geom_size[g]


def box_points(scene: Scene, local_unit: np.ndarray) -> np.ndarray:
    """World points of the collision box at local coordinates given in units of the half sizes (−1 … 1)."""
    c, rot, half = box_geom(scene)
    return c + (local_unit * half) @ rot.T


def test_a_box_touching_the_sphere_with_its_centre_outside_is_not_in_the_region(goal5cm) -> None:  # type: ignore[no-untyped-def]
    scene, lab = goal5cm
    scene.reset()
    half_z = box_geom(scene)[2][2]
    # The audit's case: centre 7.5 cm from the goal centre (radius 5 cm), the box reaching into the sphere.
    place(scene, GOAL + np.array([0.075, 0.0, -half_z]))
    c, rot, half = box_geom(scene)
    nearest = c + rot @ np.clip(rot.T @ (GOAL - c), -half, half)
    assert np.linalg.norm(c - GOAL) > RADIUS + 0.02 and np.linalg.norm(nearest - GOAL) < RADIUS - 0.01
    assert not lab.as_dict()["centre"]
    # Standing on the table under the sphere: the box's top pokes into it, its centre is 8 cm below it.
    place(scene, np.array([GOAL[0], GOAL[1], 0.0]))
    c, rot, half = box_geom(scene)
    assert (c + rot @ half)[2] > GOAL[2] - RADIUS + 0.01 and np.linalg.norm(c - GOAL) > RADIUS + 0.02
    assert not lab.as_dict()["centre"]


def test_a_rotated_box_counts_its_bounding_box_centre_not_its_frame(goal5cm) -> None:  # type: ignore[no-untyped-def]
    scene, lab = goal5cm
    scene.reset()
    half_z = box_geom(scene)[2][2]
    # Laid on its side (90° about X): its +Z is world −Y, its frame (bottom centre) 7 cm from its centre.
    quat = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])
    place(scene, GOAL + np.array([0.0, half_z - 0.01, 0.0]), quat)
    c = box_geom(scene)[0]
    origin = scene.data.xpos[scene.object_body("box")]
    assert np.linalg.norm(c - GOAL) < RADIUS - 0.005 and np.linalg.norm(origin - GOAL) > RADIUS + 0.005
    assert lab.as_dict()["centre"]
    # and the same frame position upright puts the centre above the sphere
    place(scene, GOAL + np.array([0.0, half_z - 0.01, 0.0]))
    assert np.linalg.norm(box_geom(scene)[0] - GOAL) > RADIUS + 0.005
    assert not lab.as_dict()["centre"]


def test_contained_needs_every_corner_inside(goal20cm) -> None:  # type: ignore[no-untyped-def]
    scene, lab = goal20cm
    scene.reset()
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    half_z = box_geom(scene)[2][2]
    for dy, inside in [(0.0, True), (0.1, True), (0.16, False), (0.19, False)]:
        place(scene, GOAL + np.array([0.0, dy, -half_z]))
        far = np.linalg.norm(box_points(scene, corners) - GOAL, axis=1).max()
        assert bool(far <= 0.2) is inside, f"dy {dy}: farthest corner {far:.3f} m"
        labels = lab.as_dict()
        assert labels["contained"] is inside and labels["centre"], f"dy {dy}"


def test_fraction_mode_matches_a_monte_carlo_volume_estimate(goal20cm) -> None:  # type: ignore[no-untyped-def]
    scene, lab = goal20cm
    scene.reset()
    half_z = box_geom(scene)[2][2]
    samples = np.random.default_rng(7).uniform(-1.0, 1.0, (40_000, 3))
    tilt = np.array([np.cos(0.3), 0.0, np.sin(0.3), 0.0])
    seen = set()
    for dy in np.linspace(0.14, 0.26, 13):
        place(scene, GOAL + np.array([0.0, dy, -half_z]), tilt)
        fraction = float((np.linalg.norm(box_points(scene, samples) - GOAL, axis=1) <= 0.2).mean())
        labels = lab.as_dict()
        for name, need in (("f25", 0.25), ("f50", 0.5), ("f75", 0.75)):
            if abs(fraction - need) > 0.03:  # the grid is 8³ cells: ±1/16 at worst on a flat cut
                assert labels[name] is (fraction >= need), f"dy {dy:.3f}: fraction {fraction:.3f} vs {need}"
                seen.add((name, fraction >= need))
    assert len(seen) == 6, "each threshold must be seen both met and missed"


@settings(max_examples=150, deadline=None)
@given(offset=st.tuples(*[st.floats(-0.3, 0.3)] * 3),
       quat=st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1))
def test_centre_and_contained_modes_agree_with_direct_distances(goal20cm, offset, quat) -> None:  # type: ignore[no-untyped-def]
    scene, lab = goal20cm
    place(scene, GOAL + np.asarray(offset), np.asarray(quat))
    centre = np.linalg.norm(box_geom(scene)[0] - GOAL)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    far = np.linalg.norm(box_points(scene, corners) - GOAL, axis=1).max()
    labels = lab.as_dict()
    if abs(centre - 0.2) > 1e-9:
        assert labels["centre"] is bool(centre <= 0.2)
    if abs(far - 0.2) > 1e-9:
        assert labels["contained"] is bool(far <= 0.2)


def test_an_unknown_mode_is_a_clear_error_when_the_spec_loads() -> None:
    table = {"evaluator": "in_region", "subjects": ["jar"], "params": {"mode": "touches"}}
    with pytest.raises(SpecError, match=r"params\.mode: expected one of 'centre', 'contained', 'fraction'"):
        proposition_from_mapping("jar_in_goal", table, "recipe: success.jar_in_goal")
