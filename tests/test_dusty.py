"""Dusty: the wipe, the food never touched, and "clean before pour", each judged from raw MuJoCo data.

Safe success is the family contract (tests/test_families.py). Here, with a probe that reads raw MuJoCo
state after every control step (``data.contact``, body poses, the dust's mocap positions), independently of
the predicates:

* the skeleton's wipe phase: dust specks disappear only at steps where the sponge touches the tray, every
  remaining speck keeps its place in the tray's frame, and none is left; from the press's first touch to the
  last stroke the sponge stays on the tray (> 95 % of the steps) with a median normal force (raw
  ``mj_contactForce``) within the strokes' bound and a peak within the press's;
* a planted unsafe carrier grasp, the fingers closed on the food instead of the bowl's rim: the attempt ends
  unsafe (``food_not_touched``) at exactly the first step where a robot geom touches the food;
* pouring onto the still dusty tray (no wipe): unsafe (``clean_before_pour``) at the step the food's centre
  enters the tray's cavity, with dust still on it.
* a bowl's pour (task 25) is kept, and the candy ends inside the tray's bounding box at rest;
* a tray as the source (task 12): carried level, turned about its far edge over the destination, the food
  leaving it above the destination's cavity and ending inside it at rest; it is held by its wall nearer the
  robot (every grasp the gate keeps, from raw poses).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.motion import Pose
from mgdata.paths import grasps_dir
from mgdata.sim.assets import get_model
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene, build_scene
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeletons.dusty import DustySkeleton
from mgdata.tasks.recipe import Recipe
from tests.helpers import rawdata
from tests.helpers.probed import probed_attempt, with_penetration_bound

TASK = 1


@pytest.fixture(scope="module")
def grasps() -> GraspDB:
    return GraspDB.load_dir(grasps_dir())


@pytest.fixture(scope="module")
def recipe() -> Recipe:
    return load_family_recipe("dusty")


def _descendant_geoms(m, root: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Geoms of body ``root`` and all its descendants (the whole robot under its base)."""
    inside = np.zeros(m.nbody, dtype=bool)
    inside[root] = True
    for b in range(root + 1, m.nbody):
        inside[b] = inside[m.body_parentid[b]]
    return np.flatnonzero(inside[m.geom_bodyid])


class _Probe(JointController):
    """After every control step, from raw MuJoCo: does a robot geom touch the food, does a sponge geom touch
    a tray geom, which specks are left (mocap z above the floor), the specks' positions in the tray's frame,
    and is the food's bounding-box centre inside the tray's cavity (from the tray model's dimensions)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.robot = set(_descendant_geoms(m, m.body("base").id).tolist())
        self.food = set(rawdata.subtree_geoms(m, m.body("food").id).tolist())
        self.sponge = set(rawdata.subtree_geoms(m, m.body("sponge").id).tolist())
        self.tray = set(rawdata.subtree_geoms(m, m.body("dest").id).tolist())
        self.specks = np.array([m.body_mocapid[b] for b in range(m.nbody)
                                if m.body(b).name.startswith("dust/d")])
        geo = get_model(scene.task.object("dest").model).geometry
        hx, hy, _ = geo["half_extents"]
        wall, bottom = geo["wall"], geo["bottom"]
        self.cavity = (hx - wall, hy - wall, bottom, get_model(scene.task.object("dest").model).size[2])
        self.touch_food: list[bool] = []
        self.sponge_on_tray: list[bool] = []
        self.left: list[np.ndarray] = []
        self.local: list[np.ndarray] = []
        self.food_in_tray: list[bool] = []
        self.press: list[float] = []

    def _touching(self, a: set[int], b: set[int]) -> bool:
        d = self.scene.data
        return any((c.geom1 in a and c.geom2 in b) or (c.geom1 in b and c.geom2 in a)
                   for c in d.contact[:d.ncon])

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        self.touch_food.append(self._touching(self.robot, self.food))
        self.sponge_on_tray.append(self._touching(self.sponge, self.tray))
        force, total = np.zeros(6), 0.0
        for i, c in enumerate(d.contact[:d.ncon]):
            pair = {c.geom1, c.geom2}
            if pair & self.sponge and pair & self.tray:
                mujoco.mj_contactForce(m, d, i, force)
                total += float(force[0])
        self.press.append(total)
        tray = m.body("dest").id
        rot = d.xmat[tray].reshape(3, 3)
        self.left.append(d.mocap_pos[self.specks, 2] > m.geom("floor").pos[2])
        self.local.append((d.mocap_pos[self.specks] - d.xpos[tray]) @ rot)
        centre = (rawdata.box_centre(m, d, m.body("food").id) - d.xpos[tray]) @ rot
        hx, hy, floor, rim = self.cavity
        self.food_in_tray.append(bool(abs(centre[0]) <= hx + 0.005 and abs(centre[1]) <= hy + 0.005
                                      and floor - 0.005 <= centre[2] <= rim))


def _probed(recipe: Recipe, grasps: GraspDB, skeleton: DustySkeleton):  # type: ignore[no-untyped-def]
    result, frames, _, probe = probed_attempt(base_task(recipe, TASK), recipe, grasps, skeleton, _Probe)
    return result, frames, probe


class _WipeOnly(DustySkeleton):
    """The skeleton's own segments up to lifting the sponge off the wiped tray."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        segs = list(super().segments(ctx))
        return segs[: [seg.name for seg in segs].index("wipe_up") + 1]


@pytest.mark.slow
def test_the_wipe_removes_dust_only_where_the_sponge_touches_the_tray(recipe: Recipe,
                                                                     grasps: GraspDB) -> None:
    result, _, probe = _probed(recipe, grasps, _WipeOnly())
    assert result.stage == "goal_not_reached", (result.stage, result.reason)  # the pour never happened
    left = np.array(probe.left)
    assert left[0].all() and not left[-1].any(), "every speck there at the start, none after the wipe"
    gone = np.flatnonzero(np.any(left[:-1] & ~left[1:], axis=1)) + 1  # steps where some speck vanished
    assert len(gone) > 0 and all(probe.sponge_on_tray[t] for t in gone), "wiped only while touching"
    touching = np.flatnonzero(probe.sponge_on_tray)
    span = slice(touching[0], touching[-1] + 1)  # from the press's first touch to the end of the strokes
    assert np.mean(np.array(probe.sponge_on_tray)[span]) > 0.95, "the strokes keep the sponge on the tray"
    press = np.array(probe.press)[span]
    stroke = float(recipe.params["max_stroke_force"])
    assert np.median(press) <= stroke and np.max(press) <= float(recipe.params["max_press_force"])
    local = np.array(probe.local)
    for t in range(1, len(local)):  # a speck still there sits where it sat on the tray (it moves with it)
        keep = left[t]
        np.testing.assert_allclose(local[t][keep], local[0][keep], atol=1e-6)


class _GraspOnTheFood(DustySkeleton):
    """A planted unsafe carrier grasp: straight down onto the food in the bowl and close on it."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        bowl = (("hand", "source"), ("hand", "food"))
        return [s.gripper("open", "open", steps=8), s.free("over_food", "over_food"),
                s.linear("onto_food", "onto_food", allow=bowl), s.gripper("close", "close", steps=14)]

    def resolve(self, name: str, ctx: Context) -> Pose:
        food = ctx.object_pose("food").pos
        size = ctx.scene.object_model("food").size
        quat = ctx.commanded_tcp().quat  # the hand points down at home
        if name == "over_food":
            return Pose(food + np.array([0.0, 0.0, 0.15]), quat)
        if name == "onto_food":
            return Pose(food + np.array([0.0, 0.0, size[2] / 2]), quat)
        return super().resolve(name, ctx)


def test_grasping_the_carrier_on_the_food_is_unsafe_at_the_first_touch(recipe: Recipe,
                                                                      grasps: GraspDB) -> None:
    recipe = with_penetration_bound(recipe, 0.02)  # reaching into the bowl for the candy, the hand shoves
    result, frames, probe = _probed(recipe, grasps, _GraspOnTheFood())  # the bowl mm into the table
    assert result.stage == "unsafe" and not result.kept, (result.stage, result.reason)
    first = probe.touch_food.index(True) + 1  # frame t is the state after control step t
    assert result.t_violation["food_not_touched"] == first == len(frames) - 1
    assert frames[first].violated[0] and not frames[first - 1].violated[0]


class _PourWithoutWiping(DustySkeleton):
    """The skeleton without its wipe and sponge phases: pick the bowl and pour onto the dusty tray."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        segs = list(super().segments(ctx))
        return segs[[seg.name for seg in segs].index("open"):]


@pytest.mark.slow
def test_pouring_onto_the_dusty_tray_breaks_clean_before_pour(recipe: Recipe, grasps: GraspDB) -> None:
    result, frames, probe = _probed(recipe, grasps, _PourWithoutWiping())
    assert result.stage == "unsafe", (result.stage, result.reason)
    landed = probe.food_in_tray.index(True) + 1
    t_v = result.t_violation["clean_before_pour"]
    assert t_v is not None and abs(t_v - landed) <= 1, (t_v, landed)
    assert len(frames) - 1 == t_v and probe.left[t_v - 1].all(), "all the dust still on the tray"
    assert result.t_violation["food_not_touched"] is None


RAMP_S = 3.0


def _tilt_bowl(recipe: Recipe, tilt_deg: float) -> tuple[float, float]:
    """Raise the task's bowl with its food 25 cm, turn it slowly (over ``RAMP_S``) about a horizontal axis
    through its foot to ``tilt_deg`` and hold it there 1 s, driving its free joint directly each physics
    step (a kinematic hand); return the food centre's distance (m) from the bowl's axis and its height
    along it, in the bowl's frame, from raw MuJoCo data."""
    from mgdata.sim.scene import build_scene

    scene = build_scene(base_task(recipe, TASK))
    m, d = scene.model, scene.data
    bowl, food = m.body("source"), m.body("food")
    qa, da = m.jnt_qposadr[bowl.jntadr[0]], m.jnt_dofadr[bowl.jntadr[0]]
    fa = m.jnt_qposadr[food.jntadr[0]]
    d.qpos[qa + 2] += 0.25
    d.qpos[fa + 2] += 0.25
    d.qvel[:] = 0.0
    pos0, quat0 = d.qpos[qa:qa + 3].copy(), d.qpos[qa + 3:qa + 7].copy()
    ramp, hold = round(RAMP_S / m.opt.timestep), round(1.0 / m.opt.timestep)
    rate = math.radians(tilt_deg) / (ramp * m.opt.timestep)  # rad/s
    for k in range(ramp + hold):
        half = math.radians(tilt_deg) * min(1.0, k / ramp) / 2
        turn = np.array([math.cos(half), math.sin(half), 0.0, 0.0])  # about world x
        d.qpos[qa:qa + 3] = pos0
        mujoco.mju_mulQuat(d.qpos[qa + 3:qa + 7], turn, quat0)
        d.qvel[da:da + 6] = 0.0
        if k < ramp:  # the free joint's angular velocity is in the body frame
            d.qvel[da + 3:da + 6] = d.xmat[bowl.id].reshape(3, 3).T @ np.array([rate, 0.0, 0.0])
        mujoco.mj_step(m, d)
    rot = d.xmat[bowl.id].reshape(3, 3)
    local = (rawdata.box_centre(m, d, food.id) - d.xpos[bowl.id]) @ rot
    return float(np.hypot(local[0], local[1])), float(local[2])


def test_the_pour_tilts_past_where_the_food_leaves_the_bowl(recipe: Recipe) -> None:
    """The pour's least tilt (:func:`mgdata.skeleton.pour.slide_tilt` plus the recipe's margin: the bowl's
    lowest wall steeper than the friction angle) against physics: there the food has left the slowly turned
    bowl, while at 20° it stays in (the rig holds food). The static bound is conservative: turned like this,
    the candy already slid out at 45° (it stayed at 30°, or not when turned faster: its slide down the floor
    carries it over the low rim)."""
    from types import SimpleNamespace

    from mgdata.sim.scene import build_scene
    from mgdata.skeleton.pour import slide_tilt

    scene = build_scene(base_task(recipe, TASK))
    geo = scene.object_model("source").geometry
    least = math.degrees(slide_tilt(SimpleNamespace(scene=scene)))
    least += float(recipe.params["pour_slide_margin_deg"])
    assert 90.0 < least < 150.0
    r, z = _tilt_bowl(recipe, 20.0)
    assert r < float(geo["rim_radius"]) and 0.0 < z < float(geo["height"]), "still in the bowl"
    r, z = _tilt_bowl(recipe, least)
    assert r > float(geo["rim_radius"]) + 0.02 or z > float(geo["height"]) + 0.02, "out of the bowl"


class _EndProbe(JointController):
    """After every control step, from raw MuJoCo: the food's box centre in the tray's frame, whether it is
    inside the tray's own bounding box (from its geoms; ``dest_box``, in its frame), and the source's tilt
    from the vertical (deg)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        self.food_local: list[np.ndarray] = []
        self.inside: list[bool] = []
        self.bowl_tilt: list[float] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        tray, bowl = m.body("dest").id, m.body("source").id
        lo, hi = rawdata.local_box(m, d, tray)
        self.dest_box = (lo, hi)
        local = (rawdata.box_centre(m, d, m.body("food").id) - d.xpos[tray]) @ d.xmat[tray].reshape(3, 3)
        self.food_local.append(local)
        self.inside.append(bool(np.all((local >= lo) & (local <= hi))))
        self.bowl_tilt.append(math.degrees(math.acos(np.clip(d.xmat[bowl].reshape(3, 3)[2, 2], -1.0, 1.0))))


BOWL_POUR = 25  # a bowl source


def test_a_bowl_pour_lands_the_candy_in_the_tray_at_rest(recipe: Recipe, grasps: GraspDB) -> None:
    """Task 25's first attempt, a bowl poured over the rim opposite the hand, is kept: from raw MuJoCo data
    the candy starts outside the tray, in the bowl, and ends with its box centre inside the tray's bounding
    box, at rest over the gate's last frames, the bowl tilted past the static sliding tilt."""
    task = base_task(recipe, BOWL_POUR)
    assert task.object("source").model.startswith("bowl/")
    result, _, _, probe = probed_attempt(task, recipe, grasps, DustySkeleton(), _EndProbe)
    assert result.kept, (result.stage, result.segment, result.reason)
    assert probe.bowl_tilt[-1] > 90.0, probe.bowl_tilt[-1]
    hold = int(recipe.tasks.hold_steps)
    assert all(probe.inside[-hold:]), "the candy ends inside the tray"
    end = np.array(probe.food_local[-hold:])
    assert float(np.max(np.linalg.norm(np.diff(end, axis=0), axis=1))) * 20.0 < 0.01, "and at rest"
    assert not probe.inside[0], "it started outside, in the bowl"


class _TrayProbe(_EndProbe):
    """:class:`_EndProbe` plus, after every control step, the source's horizontal position and whether the
    food's box centre is inside the source's own bounding box."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        self.source_xy: list[np.ndarray] = []
        self.food_in_source: list[bool] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        src = m.body("source").id
        lo, hi = rawdata.local_box(m, d, src)
        food = rawdata.box_centre(m, d, m.body("food").id)
        local = (food - d.xpos[src]) @ d.xmat[src].reshape(3, 3)
        self.source_xy.append(d.xpos[src][:2].copy())
        self.food_in_source.append(bool(np.all((local >= lo) & (local <= hi))))


TRAY_SOURCE = 12  # one of the base tasks whose source is a tray (12, 13, 15, 17, 18, 21)
def test_a_tray_source_is_carried_level_and_turned_about_the_edge_over_the_tray(recipe: Recipe,
                                                                              grasps: GraspDB) -> None:
    """The paper's dusty source, a tray (task 12): from raw MuJoCo data it is carried level (under 10° from
    the vertical until it has moved 30 cm across the table; a joint-space carry had tipped it 30°), then
    turned past the food's sliding tilt about its far edge held over the destination, so that the food
    leaves it for good above the destination's cavity (its centre inside the destination's bounding box in
    the horizontal; it may hop out of the source's box and back as the tilt sets off) and ends inside it,
    at rest."""
    task = base_task(recipe, TRAY_SOURCE)
    assert task.object("source").model.startswith("tray/")
    assert "from the serving tray into the tray" in task.prompt
    result, _, _, probe = probed_attempt(task, recipe, grasps, DustySkeleton(), _TrayProbe)
    assert result.kept, (result.stage, result.segment, result.reason)
    start = probe.source_xy[0]
    tipped = next(t for t, tilt in enumerate(probe.bowl_tilt) if tilt > 10.0)
    assert np.linalg.norm(probe.source_xy[tipped] - start) > 0.30, "carried level across the table"
    assert max(probe.bowl_tilt) > 120.0
    left = max(t for t in range(tipped, len(probe.food_in_source)) if probe.food_in_source[t]) + 1  # for good
    lo, hi = probe.dest_box
    at = probe.food_local[left]
    assert np.all(at[:2] >= lo[:2]) and np.all(at[:2] <= hi[:2]), (at, lo, hi)
    hold = int(recipe.tasks.hold_steps)
    assert all(probe.inside[-hold:]), "the candy ends inside the tray"
    end = np.array(probe.food_local[-hold:])
    assert float(np.max(np.linalg.norm(np.diff(end, axis=0), axis=1))) * 20.0 < 0.01, "and at rest"


@pytest.mark.parametrize("task_id", [12, 13])  # a tray pinched on either near wall, and on its long one only
def test_a_tray_source_is_held_by_its_wall_nearer_the_robot(recipe: Recipe, grasps: GraspDB,
                                                            task_id: int) -> None:
    """Every carrier grasp the gate keeps for a tray source puts the TCP between the robot's base and the
    tray's centre, in the roll whose +x axis (the hand's, from the grasp's frame on the tray's raw MuJoCo
    pose) is the axis the tilt turns about, radius × up: the tray turns about its far edge with the hand
    toward the robot. A pinch on the far wall needs the hand turned round at the stance, which the wrist
    reaches only on a flipped shoulder where the tilt cannot go on; the near pinch's other roll lost its
    tilt's IK at every stance (docs/families.md)."""
    task = base_task(recipe, task_id)
    model = task.object("source").model
    assert model.startswith("tray/")
    scene = build_scene(task)
    m, d = scene.model, scene.data
    src = m.body("source").id
    frame = np.eye(4)
    frame[:3, :3], frame[:3, 3] = d.xmat[src].reshape(3, 3), d.xpos[src]
    towards_robot = d.xpos[m.body("base").id][:2] - d.xpos[src][:2]
    by_id = {g.id: g for g in grasps.grasps(model, status="valid")}
    held = task.gate["grasps"]
    assert held
    for gid in held:
        tcp = frame @ by_id[gid].matrix()
        radius = tcp[:2, 3] - d.xpos[src][:2]
        assert radius @ towards_robot > 0.0, gid
        assert np.cross([*radius, 0.0], [0.0, 0.0, 1.0]) @ tcp[:3, 0] > 0.0, gid


def _finger_food_gap(scene: Scene, tcp: np.ndarray) -> float:
    """m between the open fingers' collision geoms and the food's, the arm put (IK) at the TCP pose ``tcp``,
    from raw ``mj_geomDistance``."""
    from mgdata.motion import MotionPlanner
    from mgdata.motion.config import load_motion_config
    from mgdata.sim.robot import FINGER_BODIES, GRIPPER_MAX_OPENING, arm_qpos_adr, finger_qpos_adr

    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_copyData(d, m, scene.data)
    planner = MotionPlanner(m, load_motion_config())
    planner.sync(d)
    d.qpos[arm_qpos_adr(m)] = planner.ik(Pose.from_matrix(tcp), scene.arm_q(), np.random.default_rng(0))
    d.qpos[finger_qpos_adr(m)] = GRIPPER_MAX_OPENING / 2
    mujoco.mj_forward(m, d)
    fingers = [g for b in FINGER_BODIES for g in rawdata.subtree_geoms(m, m.body(b).id)
               if m.geom_contype[g] or m.geom_conaffinity[g]]
    food = rawdata.subtree_geoms(m, m.body("food").id)
    return min(mujoco.mj_geomDistance(m, d, int(a), int(b), 0.1, None) for a in fingers for b in food)


def test_a_bowl_grasp_whose_finger_back_comes_over_the_candy_is_not_kept(recipe: Recipe,
                                                                        grasps: GraspDB) -> None:
    """The carrier grasps the gate keeps leave the open fingers' collision geometry over 5 mm from the
    candy's (raw ``mj_geomDistance``, the arm put at each grasp), on a bowl's base task; and a layout whose
    candy lies in the bowl's middle (task 2, draw 5), where the back of the finger inside the bowl comes
    within 5 mm of it on the far-side pinches, is rejected (``reach.grasps``): checked with the pad's centre
    alone, it was accepted and both its attempts touched the candy (``unsafe``)."""
    from mgdata.engine.init_gate import check_initial_state
    from mgdata.skeleton.skeleton import Infeasible
    from mgdata.tasks.base import draw_task

    def frames(task):  # type: ignore[no-untyped-def]
        scene = build_scene(task)
        src = scene.model.body("source").id
        frame = np.eye(4)
        frame[:3, :3], frame[:3, 3] = scene.data.xmat[src].reshape(3, 3), scene.data.xpos[src]
        return scene, {g.id: frame @ g.matrix() for g in grasps.grasps(task.object("source").model, "valid")}

    kept = base_task(recipe, BOWL_POUR)
    scene, at = frames(kept)
    assert all(_finger_food_gap(scene, at[g]) > 0.005 for g in kept.gate["grasps"])
    middle = draw_task(recipe, 2, 5)
    scene, at = frames(middle)
    assert _finger_food_gap(scene, at["rim_225_r0"]) < 0.005
    with pytest.raises(Infeasible) as why:
        check_initial_state(middle, recipe, grasps)
    assert why.value.rule == "reach.grasps"
