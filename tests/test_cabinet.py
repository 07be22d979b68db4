"""Cabinet: the goal predicates against raw MuJoCo, a planted unsafe opening, and a demonstration that ends
with the target in the closed drawer.

* ``inside(target, container=cabinet)`` and ``closed(cabinet)`` agree with the test's own measurement: the
  target's geom bounding box against the drawer's inner box rebuilt from the drawer's geoms
  (``rawdata.inside_drawer``), and the slide joint's ``qpos`` against its range.
* Opening the drawer without moving the bottle out of its way first (the planted unsafe variant): the
  drawer pushes the bottle over; the attempt ends unsafe at exactly the first step at which the bottle's tilt,
  read from ``xmat``, passes 45°, after the drawer (not the hand) touched it.
* The real skeleton: the target ends inside the closed drawer, at rest (raw measurement; slow).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task, check_initial_state
from mgdata.errors import RecipeError
from mgdata.grasps.db import GraspDB
from mgdata.motion import AllowedContacts
from mgdata.paths import grasps_dir
from mgdata.record.episode import MemorySink
from mgdata.scenarios.conditions import variant
from mgdata.sim.assets import get_model
from mgdata.sim.controller import JointController
from mgdata.sim.predicates import Contacts, compile_check
from mgdata.sim.scene import Scene, build_scene
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeletons.cabinet import CabinetSkeleton
from mgdata.spec import EVALUATORS
from mgdata.tasks.base import draw_task
from mgdata.tasks.layout_rules import parse_layout
from tests.helpers import rawdata
from tests.helpers.probed import probed_attempt

SLACK = 0.005  # the predicate's default margin
BAND = 0.002   # m: the model's bounding box and the geoms' may differ by this much


@pytest.fixture(scope="module")
def grasps() -> GraspDB:
    return GraspDB.load_dir(grasps_dir())


def _params(name: str, **given: object) -> dict:
    return {p.name: given.get(p.name, p.default) for p in EVALUATORS[name].params}


def test_inside_and_closed_match_raw_geometry_and_qpos() -> None:
    recipe = load_family_recipe("cabinet")
    scene = build_scene(draw_task(recipe, 0))  # the placer's draw 0 (no gate needed for the predicates)
    m, d = scene.model, scene.data
    inside = compile_check(scene, "inside", "target", _params("inside", container="cabinet"))
    closed = compile_check(scene, "closed", "cabinet", _params("closed"))
    drawer, target = m.body("cabinet/drawer").id, m.body("target").id
    slide = m.joint("cabinet/drawer_slide")
    q_adr, t_adr = m.jnt_qposadr[slide.id], m.jnt_qposadr[m.body("target").jntadr[0]]
    lo, hi = slide.range
    rng = np.random.default_rng(7)
    seen = {(True, True): 0, (True, False): 0, (False, True): 0, (False, False): 0}
    for _ in range(150):
        q = float(rng.choice([0.0, rng.uniform(lo, 0.1 * hi), rng.uniform(lo, hi)]))
        d.qpos[q_adr] = q
        mujoco.mj_forward(m, d)
        ilo, ihi = rawdata.drawer_interior(m, drawer)
        local = rng.uniform(ilo - 0.06, ihi + 0.03)  # the target's origin (bottom centre), drawer frame
        local[2] = rng.choice([ilo[2] + 0.002, local[2]])
        world = d.xpos[drawer] + d.xmat[drawer].reshape(3, 3) @ local
        yaw = rng.uniform(-np.pi, np.pi)
        d.qpos[t_adr:t_adr + 3] = world
        d.qpos[t_adr + 3:t_adr + 7] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        mujoco.mj_forward(m, d)
        contacts = Contacts(scene)
        label = inside(contacts)
        if rawdata.inside_drawer(m, d, target, drawer, SLACK - BAND):
            assert label, (q, local)
        if not rawdata.inside_drawer(m, d, target, drawer, SLACK + BAND):
            assert not label, (q, local)
        assert closed(contacts) == (d.qpos[q_adr] <= lo + 0.05 * (hi - lo) + 1e-12), q
        seen[(label, closed(contacts))] += 1
    assert min(seen.values()) >= 5, seen  # every combination was exercised


class _Probe(JointController):
    """After every control step: the obstacle's tilt (deg, from ``xmat``), the slide joint's ``qpos``, and
    whether the drawer's or the robot's geoms touch the obstacle (raw ``data.contact``)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.obstacle = m.body("obstacle").id
        self.q_adr = m.jnt_qposadr[m.joint("cabinet/drawer_slide").id]
        self.drawer = set(np.flatnonzero(m.geom_bodyid == m.body("cabinet/drawer").id).tolist())
        robot_bodies = [b for b in range(m.nbody)
                        if m.body(b).name.startswith(("link", "hand", "left_", "right_"))]
        self.robot = set(np.flatnonzero(np.isin(m.geom_bodyid, robot_bodies)).tolist())
        self.mine = set(np.flatnonzero(m.geom_bodyid == self.obstacle).tolist())
        self.tilt: list[float] = []
        self.z: list[float] = []  # the obstacle's origin height (m; the table top is at 0)
        self.q: list[float] = []
        self.drawer_touch: list[bool] = []
        self.robot_touch: list[bool] = []

    def _touch(self, other: set[int]) -> bool:
        d = self.scene.data
        return any((c.geom1 in self.mine and c.geom2 in other) or (c.geom2 in self.mine and c.geom1 in other)
                   for c in d.contact[:d.ncon])

    def step(self) -> None:
        super().step()
        d = self.scene.data
        self.tilt.append(float(np.degrees(np.arccos(np.clip(d.xmat[self.obstacle][8], -1.0, 1.0)))))
        self.z.append(float(d.xpos[self.obstacle][2]))
        self.q.append(float(d.qpos[self.q_adr]))
        self.drawer_touch.append(self._touch(self.drawer))
        self.robot_touch.append(self._touch(self.robot))


class _OpenRightAway(CabinetSkeleton):
    """The planted unsafe variant: open the drawer without relocating what stands in its way (the planner
    may pass the obstacle, so that only the drawer decides)."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        assert "obstacle" in self.in_the_way(ctx)
        near = AllowedContacts((("base", "obstacle"),))
        return [dataclasses.replace(seg, allow=seg.allow + near) for seg in self._open(ctx)]


def _bottle_in_front_of_the_drawer(task):  # type: ignore[no-untyped-def]
    """``task`` with its bottle standing 12 cm in front of the closed drawer, 12 cm off the handle's axis."""
    cab = task.object("cabinet")
    front = get_model(cab.model).geometry["front_x"]
    c, s = np.cos(cab.yaw), np.sin(cab.yaw)
    x, y = front + 0.12, 0.12
    pos = (cab.pos[0] + c * x - s * y, cab.pos[1] + s * x + c * y, task.object("obstacle").pos[2])
    objects = tuple(dataclasses.replace(o, pos=pos) if o.name == "obstacle" else o for o in task.objects)
    return dataclasses.replace(task, objects=objects)


def test_opening_the_drawer_into_the_bottle_is_unsafe_at_the_tipping_step(grasps: GraspDB) -> None:
    recipe = load_family_recipe("cabinet")
    task = _bottle_in_front_of_the_drawer(base_task(recipe, 1))
    result, frames, meta, probe = probed_attempt(task, recipe, grasps, _OpenRightAway(), _Probe)
    assert result.stage == "unsafe" and not result.kept and not meta.kept, (result.stage, result.reason)
    tipped = next(t for t, tilt in enumerate(probe.tilt, start=1) if tilt > 45.0)
    assert result.t_violation["obstacle_stays_upright"] == tipped == len(frames) - 1
    first_touch = next(t for t, touch in enumerate(probe.drawer_touch, start=1) if touch)
    assert first_touch < tipped and probe.q[first_touch - 1] > 0.05  # the opening drawer hit it ...
    assert not any(probe.robot_touch[:first_touch])                  # ... before the robot ever touched it
    assert all(v is None for k, v in result.t_violation.items() if k != "obstacle_stays_upright")


class _GapProbe(_Probe):
    """:class:`_Probe` plus, after every control step, the smallest distance (m, ``mj_geomDistance``, capped
    at 10 cm) between the robot's colliding geoms and the obstacle's."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self.robot_c = [g for g in sorted(self.robot) if colliding[g]]
        self.mine_c = [g for g in sorted(self.mine) if colliding[g]]
        self.gap: list[float] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        reach = m.geom_rbound
        near = [(a, b) for a in self.robot_c for b in self.mine_c  # bounding spheres within 10 cm
                if np.linalg.norm(d.geom_xpos[a] - d.geom_xpos[b]) < reach[a] + reach[b] + 0.1]
        self.gap.append(min((mujoco.mj_geomDistance(m, d, a, b, 0.1, None) for a, b in near), default=0.1))


def test_a_relocated_bottle_stands_clear_of_the_arm_while_the_drawer_moves(grasps: GraspDB) -> None:
    """Task 3 (draw 0): the bottle stands in the drawer's way and is put down elsewhere. Before the put-down
    spot kept clear of the arm's later motions, the wrist hit such a bottle while pulling the drawer open
    (task 7's then draw 3: ``plan_fail``, link6 <-> obstacle); now, measured from raw MuJoCo: once released
    the robot stays clear of it, the drawer never touches it, and it never tilts."""
    recipe = load_family_recipe("cabinet")
    task = base_task(recipe, 3)
    assert "obstacle" in task.gate["in_the_way"]
    result, frames, _, probe = probed_attempt(task, recipe, grasps, CabinetSkeleton(), _GapProbe)
    assert result.kept, (result.stage, result.segment, result.reason)
    released = max(t for t, touch in enumerate(probe.robot_touch) if touch)  # the relocation's release
    assert released < len(frames) // 3  # ... early in the episode: the relocation comes first
    assert min(probe.gap[released + 20:]) > 0.0, min(probe.gap[released + 20:])
    assert not any(probe.drawer_touch) and max(probe.q) > 0.2  # the drawer opened past it, untouched
    assert max(probe.tilt) < 5.0


def test_a_relocated_bottle_is_carried_upright(grasps: GraspDB) -> None:
    """A free joint-space carry to the put-down spot once tipped a side-grasped bottle past 45° (task 12, draw
    1, with the grasp DB before drawer handles had three poses: unsafe at step 160); the straight carry keeps
    it upright (raw tilt from ``xmat``). Task 4, draw 1: the bottle is in the drawer's way and is moved."""
    recipe = load_family_recipe("cabinet")
    task = base_task(recipe, 4)
    assert "obstacle" in task.gate["in_the_way"]
    result, _, _, probe = probed_attempt(task, recipe, grasps, CabinetSkeleton(), _Probe, draw=1)
    assert result.kept, (result.stage, result.segment, result.reason)
    assert any(probe.robot_touch) and max(probe.tilt) < 10.0, max(probe.tilt)
    assert result.t_violation["obstacle_stays_upright"] is None


def test_a_relocated_bottle_is_put_down_from_its_body_and_stays_down(grasps: GraspDB) -> None:
    """Task 19, draw 1: the bottle was put down from a pinch at its neck; as the fingers opened it slid 2 cm
    with one of them, and the rising hand lifted it 9 cm by its cap (``plan_fail``: the next motion started
    in contact with it). The obstacle is now moved by side grasps only (the gate's fact names no other), and
    from raw MuJoCo: once released, the bottle stands on the table (origin within 2 mm of its top, tilt under
    5°) and the robot stays clear of it."""
    recipe = load_family_recipe("cabinet")
    task = base_task(recipe, 19)
    assert "obstacle" in task.gate["in_the_way"]
    ids = task.gate["obstacle/grasps"]
    side = {g.id for g in grasps.grasps(task.object("obstacle").model) if g.approach == "side"}
    assert ids and set(ids) <= side, ids
    result, frames, _, probe = probed_attempt(task, recipe, grasps, CabinetSkeleton(), _GapProbe, draw=1)
    assert result.kept, (result.stage, result.segment, result.reason)
    released = max(t for t, touch in enumerate(probe.robot_touch) if touch)
    assert released < len(frames) // 3
    assert min(probe.gap[released + 20:]) > 0.0, min(probe.gap[released + 20:])
    assert max(probe.tilt[released:]) < 5.0
    assert max(abs(z) for z in probe.z[released:]) < 0.002, max(probe.z[released:])


def _bottle_on_the_handles_axis(task, out: float):  # type: ignore[no-untyped-def]
    """``task`` with its bottle ``out`` m in front of the drawer's handle, on the handle's axis."""
    cab = task.object("cabinet")
    hx, hy, _ = get_model(cab.model).geometry["handle_pos"]
    c, s = np.cos(cab.yaw), np.sin(cab.yaw)
    x, y = hx + out, hy
    pos = (cab.pos[0] + c * x - s * y, cab.pos[1] + s * x + c * y, task.object("obstacle").pos[2])
    objects = tuple(dataclasses.replace(o, pos=pos) if o.name == "obstacle" else o for o in task.objects)
    return dataclasses.replace(task, objects=objects)


def test_a_bottle_in_front_of_the_handle_is_a_blocker_not_a_reason_to_reject(grasps: GraspDB) -> None:
    """Task 1 with its bottle 10 cm in front of the handle, where the opening drawer would run into it (raw:
    its origin inside the open drawer's geom box, its top above the drawer's bottom). The skeleton moves it
    first, so the gate plans the handle's pre-grasp, approach and pull without it: the task passes and the
    bottle is named in the way. Before, the gate planned those motions around the bottle and rejected the
    task (``reach.handle``)."""
    recipe = load_family_recipe("cabinet")
    task = _bottle_on_the_handles_axis(base_task(recipe, 1), 0.10)
    facts = check_initial_state(task, recipe, grasps)
    assert "obstacle" in facts["in_the_way"] and facts["handle_grasps"] and facts["obstacle/grasps"]
    scene = build_scene(task)
    m, d = scene.model, scene.data
    slide = m.joint("cabinet/drawer_slide")
    d.qpos[m.jnt_qposadr[slide.id]] = recipe.variation["stroke"][0] * slide.range[1]  # the smallest stroke
    mujoco.mj_forward(m, d)
    drawer, bottle = m.body("cabinet/drawer").id, m.body("obstacle").id
    lo, hi = rawdata.local_box(m, d, drawer)
    at = (d.xpos[bottle] - d.xpos[drawer]) @ d.xmat[drawer].reshape(3, 3)
    assert np.all(at[:2] > lo[:2]) and np.all(at[:2] < hi[:2]), (at, lo, hi)
    top = d.xpos[bottle][2] + rawdata.local_box(m, d, bottle)[1][2]
    assert top > d.xpos[drawer][2] + lo[2]


def test_task_28_has_a_location_variant_that_passes_the_gate(grasps: GraspDB) -> None:
    """Issue 12's full scenario build stopped at cabinet task 28: every location proposal failed
    ``reach.handle``. The unit had moved away from the cabinet, so the nearest pre-grasp solution (which the
    bottle had vetoed in the base task) was accepted and then rejected for lying 0.10 rad from joint 2's
    limit, with a roomy solution available. Now the pre-grasp IK looks on for one keeping ``grasp_margin``:
    the first proposal passes, with the base task's handle grasps (and, the unit moved, maybe more)."""
    recipe = load_family_recipe("cabinet")
    base = base_task(recipe, 28)
    task, provenance, report = variant(recipe, base, "location", grasps)
    assert report["passed"] and report["attempts"] == 1 and provenance["kind"] == "location"
    assert set(base.gate["handle_grasps"]) <= set(task.gate["handle_grasps"])
    moved = {o.name: np.subtract(o.pos, base.object(o.name).pos)[:2] for o in task.objects}
    assert np.linalg.norm(moved["target"]) > 0.1 and np.allclose(moved["cabinet"], 0.0)


@pytest.mark.slow  # the family contract test (tests/test_families.py) replays a kept demo the same way
def test_a_demonstration_leaves_the_target_in_the_closed_drawer_at_rest(grasps: GraspDB) -> None:
    recipe = load_family_recipe("cabinet")
    ex = Executor(base_task(recipe, 2), recipe, grasps=grasps, render=False)
    try:
        result = ex.run(0, MemorySink())
        m, d = ex.scene.model, ex.scene.data
        assert result.kept, (result.stage, result.segment, result.reason)
        slide = m.joint("cabinet/drawer_slide")
        assert d.qpos[m.jnt_qposadr[slide.id]] <= 0.05 * slide.range[1]
        target = m.body("target").id
        assert rawdata.inside_drawer(m, d, target, m.body("cabinet/drawer").id, SLACK)
        assert np.linalg.norm(d.cvel[target][3:]) < 0.005 and d.xmat[target][8] > np.cos(np.radians(10))
    finally:
        ex.close()


def test_the_fixed_yaw_rule_turns_every_cabinet_front_to_the_robots_minus_y() -> None:
    recipe = load_family_recipe("cabinet")
    for k in range(3):
        scene = build_scene(draw_task(recipe, k))
        front = scene.data.xmat[scene.model.body("cabinet").id].reshape(3, 3)[:, 0]  # the cabinet's +X
        assert np.degrees(np.arccos(np.clip(front @ np.array([0.0, -1.0, 0.0]), -1, 1))) <= 3.0 + 1e-6, k


@pytest.mark.parametrize("yaw", [{"rule": "uniform", "deg": 10.0}, {"rule": "fixed"},
                                 {"rule": "fixed", "deg": 200.0}])
def test_a_bad_fixed_yaw_is_a_recipe_error(yaw: dict) -> None:
    raw = {"roles": {"cabinet": {"models": ["cabinet/*"], "region": {"x": [0.5, 0.6], "y": [0.4, 0.5]},
                                 "yaw": yaw}}}
    with pytest.raises(RecipeError, match="yaw"):
        parse_layout(raw, "recipes/x.toml: [layout]")
