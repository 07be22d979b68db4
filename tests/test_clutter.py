"""Clutter tasks admit safe-success, unsafe and failing trajectories (paper), each judged at the right step.

Safe success is the family contract (tests/test_families.py). Here: a demonstration that sweeps the open hand
through the tallest obstacle knocks it over, and one that pours the liquid out of the held container spills
it. In both the attempt ends unsafe at exactly the first frame where the test's own raw MuJoCo measurement
(obstacle tilt from ``xmat``; particles counted inside the container's own bounding box) crosses the spec's
threshold. Also: the layout rules hold in the built scenes (nothing overlaps, nothing starts tipped), and
the lift clears the clutter.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.motion import Pose
from mgdata.paths import grasps_dir
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene, build_scene
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeletons.clutter import ClutterSkeleton
from mgdata.spec import SafetySpec
from mgdata.tasks.base import draw_task
from tests.helpers import rawdata
from tests.helpers.probed import probed_attempt, with_penetration_bound


@pytest.fixture(scope="module")
def grasps() -> GraspDB:
    return GraspDB.load_dir(grasps_dir())


class _Probe(JointController):
    """Measures, from raw MuJoCo after every control step, each obstacle's tilt (deg) and the fraction of the
    liquid's particles inside the container's bounding box (its own frame, 3 cm headroom)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.obstacles = [m.body(n).id for n in scene.object_names if n.startswith("obstacle_")]
        self.particles = [b for b in range(m.nbody) if m.body(b).name.startswith("liquid/p")]
        self.container = m.body("container").id if "container" in scene.object_names else None
        self.tilts: list[list[float]] = []
        self.inside: list[float] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        self.tilts.append([float(np.degrees(np.arccos(np.clip(d.xmat[b][8], -1.0, 1.0))))
                           for b in self.obstacles])
        if self.particles and self.container is not None:
            lo, hi = rawdata.local_box(m, d, self.container)
            local = (d.xpos[self.particles] - d.xpos[self.container]) @ d.xmat[self.container].reshape(3, 3)
            ok = np.all((local >= lo - 0.005) & (local <= hi + np.array([0.005, 0.005, 0.03])), axis=1)
            self.inside.append(float(ok.mean()))


# --- layout -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("family", ["clutter_dry", "clutter_liquid"])
def test_scenes_start_apart_upright_and_on_the_table(family: str) -> None:
    recipe = load_family_recipe(family)
    for k in range(4):
        try:
            task = draw_task(recipe, k)
        except Exception:  # a rejected draw: the gate draws again
            continue
        scene = build_scene(task)
        m, d = scene.model, scene.data
        rigid = [n for n in scene.object_names if scene.object_model(n).particles is None]
        owner = {g: n for n in rigid for g in np.flatnonzero(m.geom_bodyid == m.body(n).id)}
        for c in d.contact[:d.ncon]:  # no two objects touch (the table holds them all)
            a, b = owner.get(int(c.geom1)), owner.get(int(c.geom2))
            assert not (a and b and a != b), (k, a, b)
        for n in rigid:
            b = m.body(n).id
            assert d.xmat[b][8] > np.cos(np.radians(2.0)), (k, n, "upright")
            assert abs(d.xpos[b][2]) < 0.003, (k, n, "on the table top (z = 0)")
        assert len([n for n in rigid if n.startswith("obstacle_")]) == 5


# --- unsafe: knock a fragile over ---------------------------------------------------------------------------
class _SweepThroughObstacle(ClutterSkeleton):
    """Sweep the open hand through the tallest obstacle at 80 % of its height, sideways to the line from the
    target (so that the target stays out of the way)."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        everything = tuple(("base", o.name) for o in ctx.task.objects)
        return [s.free("sweep_start", "sweep_start", allow=everything),
                s.linear("sweep", "sweep_end", allow=(*everything, ("base", "table")))]

    def resolve(self, name: str, ctx: Context) -> Pose:
        scene = ctx.scene
        tallest = max((n for n in scene.object_names if n.startswith("obstacle_")),
                      key=lambda n: scene.object_model(n).size[2])
        pos = scene.object_pose(tallest)[0]
        off = pos - scene.object_pose("target")[0]
        away = np.array([-off[1], off[0], 0.0]) / np.hypot(off[0], off[1])
        height = np.array([0.0, 0.0, 0.8 * scene.object_model(tallest).size[2]])
        quat = ctx.commanded_tcp().quat
        if name == "sweep_start":
            return Pose(pos - 0.10 * away + height, quat)
        if name == "sweep_end":
            return Pose(pos + 0.12 * away + height, quat)
        return super().resolve(name, ctx)



def test_knocking_over_a_fragile_is_unsafe_at_the_tipping_step(grasps: GraspDB) -> None:
    recipe = with_penetration_bound(load_family_recipe("clutter_dry"), 0.01)  # the sweep shoves objects
    sweep = _SweepThroughObstacle()
    result, frames, meta, probe = probed_attempt(base_task(recipe, 1), recipe, grasps, sweep, _Probe)
    assert result.stage == "unsafe" and not result.kept and not meta.kept
    tipped = next(t for t, tilts in enumerate(probe.tilts, start=1) if max(tilts) > 45.0)
    assert result.t_violation["obstacles_stay_upright"] == tipped == len(frames) - 1
    assert all(v is None or v >= tipped for v in result.t_violation.values())


# --- unsafe: spill ------------------------------------------------------------------------------------------
class _PourAfterLift(ClutterSkeleton):
    """Pick the container as the skeleton does, then turn the wrist 110° (pouring) and hold."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        segs = list(super().segments(ctx))
        lift = [seg.name for seg in segs].index("lift")
        carry = segs[lift]
        return [*segs[:lift + 1],
                s.free("pour", "pour", gripper="close", attached=carry.attached, riders=carry.riders),
                s.hold("wait", steps=60, gripper="close")]

    def resolve(self, name: str, ctx: Context) -> Pose:
        if name == "pour":
            q = ctx.q_cmd.copy()
            q[6] += np.radians(110.0) * (1.0 if q[6] < 0.5 else -1.0)
            return ctx.planner.fk(q)
        return super().resolve(name, ctx)


def test_pouring_the_liquid_out_is_a_spill_at_the_step_it_leaves(grasps: GraspDB) -> None:
    """The liquid recipe's spec without its upright term (which would stop the attempt at 15° first); the
    poured spheres land 5-7 mm deep in the table, past the recipe's bound, before the spill step."""
    recipe = with_penetration_bound(load_family_recipe("clutter_liquid"), 0.02)
    spec = recipe.spec
    kept = tuple(c for c in spec.constraints if c.id != "container_stays_upright")
    spec = SafetySpec(spec.name, kept, spec.propositions)
    task = dataclasses.replace(base_task(recipe, 0), safety=spec)
    recipe = dataclasses.replace(recipe, spec=spec)
    result, frames, _, probe = probed_attempt(task, recipe, grasps, _PourAfterLift(), _Probe)
    assert result.stage == "unsafe", (result.stage, result.reason)
    spilled = next(t for t, inside in enumerate(probe.inside, start=1) if inside < 0.85)
    t_v = result.t_violation["liquid_not_spilled"]
    assert t_v is not None and abs(t_v - spilled) <= 1, (t_v, spilled)  # the predicate's own cavity margin
    assert len(frames) - 1 == t_v


# --- the side grasp holds the wall, not the rim -------------------------------------------------------------
class _PadHeights(JointController):
    """After every control step, from raw MuJoCo: how far (m) below the container's top (its own frame, its
    geoms' box) the highest finger-container contact is (``None`` while no finger touches it)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.container = m.body("container").id
        self.fingers = {m.body(n).id for n in ("left_finger", "right_finger")}
        self.below_top: list[float | None] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        _, hi = rawdata.local_box(m, d, self.container)
        rot = d.xmat[self.container].reshape(3, 3)
        heights = [float((c.pos - d.xpos[self.container]) @ rot[:, 2]) for c in d.contact[:d.ncon]
                   if {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])} & self.fingers
                   and self.container in (int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2]))]
        self.below_top.append(float(hi[2]) - max(heights) if heights else None)


def test_side_grasp_pads_press_the_cup_wall_below_its_rim(grasps: GraspDB) -> None:
    """Task 13's tumbler is 91 mm tall: the drawn grasp height (+26-32 mm over the DB's 55 mm side grasp)
    put the pads' upper half over its rim, which the 70 N squeeze turned out of the grip in the lift.
    ``rim_clearance`` caps the raise: no finger touches the cup within 6 mm of its top."""
    # task 13's cup is tipped by its sloshing liquid after the lift (unsafe at step 108); a sphere against
    # its wall at 5.5 mm (step 94) would end the attempt before the pads have been watched that long
    recipe = with_penetration_bound(load_family_recipe("clutter_liquid"), 0.02)
    task = base_task(recipe, 13)
    result, _, _, probe = probed_attempt(task, recipe, grasps, ClutterSkeleton(), _PadHeights)
    touching = [h for h in probe.below_top if h is not None]
    assert len(touching) > 20, result.reason  # the fingers closed on the cup and held it a while
    assert min(touching) > 0.006, (min(touching), result.stage, result.reason)
