"""Stack tasks admit safe-success, unsafe and failing trajectories (paper), each judged at the right step.

Safe success is the family contract (tests/test_families.py). Here: the layout builds real stacks (each object
resting on the one below, identical models, upright), a demonstration that grasps the target first, under
the stack, topples it and is caught unsafe at exactly the first frame where the test's own raw MuJoCo
measurement (tilt from ``xquat``) passes 30°, and the multi-grab check rejects a pick that moved another
object more than 5 cm (positions set and measured in raw MuJoCo).
"""

from __future__ import annotations

from typing import TypeVar

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.motion import Pose
from mgdata.paths import grasps_dir
from mgdata.sim.assets import get_model
from mgdata.sim.controller import JointController
from mgdata.sim.robot import ROOT_BODY
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import TaskSpec
from mgdata.sim.world import TABLE_X
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.pick_and_carry import PickAndCarry
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeleton.variation import draw_variation
from mgdata.skeletons.stack import StackSkeleton
from mgdata.tasks.layout_rules import parse_layout
from mgdata.tasks.placer import DROP, place
from mgdata.tasks.recipe import Recipe
from tests.helpers import rawdata
from tests.helpers.probed import probed_attempt, with_penetration_bound

STACK = ("stack_0", "stack_1", "stack_2")


@pytest.fixture(scope="module")
def grasps() -> GraspDB:
    return GraspDB.load_dir(grasps_dir())


def _tilt_deg(d: mujoco.MjData, body: int) -> float:
    """Angle (deg) between the body's +Z and the world's +Z, from its quaternion."""
    _, x, y, _ = d.xquat[body]
    return float(np.degrees(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0))))


# --- layout -------------------------------------------------------------------------------------------------
def test_an_on_role_with_a_count_is_a_stack_of_one_model() -> None:
    layout = parse_layout({
        "roles": {"base": {"models": ["box/*"], "region": {"x": [0.5, 0.5], "y": [0.0, 0.0]}},
                  "pile": {"models": ["sponge/*", "box/carton_02"], "count": 3, "on": "base",
                           "same_model": True}}}, "test")
    for seed in range(5):
        placed = place(layout, np.random.default_rng(seed))
        base, *pile = placed.objects
        assert [o.name for o in pile] == ["pile_0", "pile_1", "pile_2"]
        assert len({o.model for o in pile}) == 1
        below = base
        for obj in pile:
            assert obj.pos[:2] == below.pos[:2]
            assert obj.pos[2] == pytest.approx(below.pos[2] + get_model(below.model).size[2] + DROP)
            below = obj


def test_stack_scenes_settle_into_upright_stacks_on_the_target() -> None:
    """Boxes carry the stack on their lid; a tray on its floor, inside its walls (the contacts between the
    bottom object and the tray all at the object's base, none against a wall)."""
    recipe = load_family_recipe("stack")
    models = {k: base_task(recipe, k).object("target").model for k in range(recipe.tasks.count)}
    trays = [k for k, model in models.items() if model.startswith("tray/")]
    assert trays and len(trays) < recipe.tasks.count  # both kinds of target are drawn
    for k in (0, 1, 2, trays[0]):
        scene = build_scene(base_task(recipe, k))
        m, d = scene.model, scene.data
        below = "target"
        assert abs(d.xpos[m.body("target").id][2]) < 0.003
        for name in STACK:
            b, under = m.body(name).id, m.body(below).id
            contacts = [c for c in d.contact[:d.ncon] if {int(m.geom_bodyid[c.geom1]),
                                                           int(m.geom_bodyid[c.geom2])} == {b, under}]
            assert contacts, (k, name, "touches the one below")
            top = d.xpos[under][2] + scene.object_model(below).size[2]
            if k in trays and below == "target":
                assert d.xpos[under][2] < d.xpos[b][2] < top - 0.005, (k, name, "inside the tray's walls")
                assert all(abs(c.pos[2] - d.xpos[b][2]) < 0.003 for c in contacts), (k, name, "on its floor")
            else:
                assert abs(d.xpos[b][2] - top) < 0.003, (k, name, "rests on the one below")
            assert np.hypot(*(d.xpos[b][:2] - d.xpos[under][:2])) < 0.005, (k, name, "centred")
            assert _tilt_deg(d, b) < 2.0, (k, name)
            below = name
        assert len({scene.object_model(n).name for n in STACK}) == 1


# --- unsafe: grasp the target first -------------------------------------------------------------------------
class _Probe(JointController):
    """Measures from raw MuJoCo after every control step each stacked object's tilt (deg, from
    ``xquat``) and height (m, ``xpos``)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        self.bodies = [scene.model.body(n).id for n in STACK]
        self.tilts: list[list[float]] = []
        self.heights: list[list[float]] = []

    def step(self) -> None:
        super().step()
        d = self.scene.data
        self.tilts.append([_tilt_deg(d, b) for b in self.bodies])
        self.heights.append([float(d.xpos[b][2]) for b in self.bodies])


UNDER = PickAndCarry("target")


class _TargetFirst(StackSkeleton):
    """Skip the unstacking: grasp the target under the stack (the hand pushes through the stacked
    objects), lift it and hold."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        everything = tuple((ROOT_BODY, o.name) for o in ctx.task.objects)
        UNDER.choose_grasp(ctx)  # among the gate's grasps, found with the stack allowed to be touched
        return [s.free("pre_grasp", "pre_grasp", allow=everything),
                s.linear("approach", "grasp", allow=everything),
                s.gripper("close", "close", steps=12),
                s.linear("lift", "lift", gripper="close", attached="target", allow=everything),
                s.hold("wait", steps=60, gripper="close")]

    def resolve(self, name: str, ctx: Context) -> Pose:
        if name == "lift":
            tcp = ctx.commanded_tcp()
            return Pose(tcp.pos + np.array([0.0, 0.0, 0.12]), tcp.quat)
        return UNDER.resolve(name, ctx) or super().resolve(name, ctx)


def test_grasping_the_target_first_topples_the_stack_and_is_unsafe_then(grasps: GraspDB) -> None:
    recipe = with_penetration_bound(load_family_recipe("stack"), 0.02)  # the falling stack lands 7 mm deep
    result, frames, meta, probe = probed_attempt(base_task(recipe, 5), recipe, grasps, _TargetFirst(), _Probe)
    assert result.stage == "unsafe" and not result.kept and not meta.kept, (result.stage, result.reason)
    tipped = next(t for t, tilts in enumerate(probe.tilts, start=1) if max(tilts) > 30.0)
    assert result.t_violation["stack_stays_upright"] == tipped == len(frames) - 1
    assert all(v is None or v >= tipped for v in result.t_violation.values())
    assert max(probe.tilts[0]) < 2.0  # it stood upright when the attempt started
    drop = max(h0 - h for h0, h in zip(probe.heights[0], probe.heights[-1], strict=True))
    # and it came down from where it stood (xpos), not only tilted in place: since the sponges have stiff
    # contacts (recipes/sim.toml [contact]) the pushed top one tips past 30° having dropped 3 mm; with the
    # default soft contact it had dropped 4 cm by then, the sponges sinking 21 mm into each other
    assert drop > 0.002


# --- multi-grab ---------------------------------------------------------------------------------------------
def test_a_pick_that_moves_another_object_over_5_cm_is_not_a_success(grasps: GraspDB) -> None:
    recipe = load_family_recipe("stack")
    task = base_task(recipe, 3)  # a carton under sponges (task 2 draws a board since the edge grasps' redo)
    ex = Executor(task, recipe, grasps=grasps, render=False)
    try:
        scene = ex.scene
        scene.reset()
        ex.planner.sync(scene.data)
        var = draw_variation(task.family, task.task_id, 0, 0, recipe.variation)
        ctx = Context(task, scene, ex.planner, var, ex.grasps, scene.arm_q())
        skeleton = StackSkeleton()
        skeleton.segments(ctx)
        skeleton.resolve("s0/pre_grasp", ctx)  # the first pick (of stack_2) starts
        m, d = scene.model, scene.data
        adr = m.jnt_qposadr[m.body_jntadr[m.body("target").id]]
        start = d.qpos[adr:adr + 3].copy()
        for shift, ok in ((0.04, True), (0.06, False)):
            d.qpos[adr:adr + 3] = start + np.array([shift, 0.0, 0.0])
            mujoco.mj_kinematics(m, d)
            moved = np.hypot(*(d.xpos[m.body("target").id][:2] - start[:2]))
            assert moved == pytest.approx(shift, abs=1e-9)
            assert skeleton.success_extra(ctx) is ok
        d.qpos[adr:adr + 3] = start
        top = m.jnt_qposadr[m.body_jntadr[m.body("stack_2").id]]
        d.qpos[top:top + 3] += np.array([0.0, 0.2, 0.1])  # the picked object itself may go anywhere
        mujoco.mj_kinematics(m, d)
        assert skeleton.success_extra(ctx)
        d.qpos[adr:adr + 3] = start + np.array([0.0, 0.06, 0.0])
        for i, name in enumerate(STACK[:2]):  # out of the way of the target's grasp (unstacked)
            a = m.jnt_qposadr[m.body_jntadr[m.body(name).id]]
            d.qpos[a:a + 3] = start + np.array([-0.1 * i, -0.25, 0.0])
        mujoco.mj_kinematics(m, d)
        ex.planner.sync(d)
        skeleton.resolve("target/pre_grasp", ctx)  # the target's pick starts: the last one moved others ...
        assert not skeleton.success_extra(ctx)  # ... which stays a failure (nothing moved since)
    finally:
        ex.close()


# --- a tray as the target -----------------------------------------------------------------------------------
class _TrayProbe(JointController):
    """Measures the target's tilt (deg, from ``xquat``), height (m), how many fingers touch it and how many
    other bodies do, after every control step."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.body = m.body("target").id
        self.fingers = {m.body(n).id for n in ("left_finger", "right_finger")}
        self.rows: list[tuple[float, float, int, int]] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        touching = rawdata.touching(m, d, self.body)
        self.rows.append((_tilt_deg(d, self.body), float(d.xpos[self.body][2]), len(touching & self.fingers),
                          len(touching - self.fingers)))
        self.centre = rawdata.box_centre(m, d, self.body)


P = TypeVar("P", bound=_TrayProbe)


def _kept_target_pick(grasps: GraspDB, recipe: Recipe, task_id: int, model: str, grasp: str,
                      probe: type[P]) -> tuple[TaskSpec, P]:
    """Base task ``task_id`` (its target a ``model…``) played by the stack skeleton under ``probe``; the
    attempt must be kept with a ``grasp…`` grasp of the target."""
    task = base_task(recipe, task_id)
    assert task.object("target").model.startswith(model)
    result, _, meta, probed = probed_attempt(task, recipe, grasps, StackSkeleton(), probe)
    assert result.kept and meta.kept, (result.stage, result.reason)
    assert result.grasp_id.startswith(grasp)
    return task, probed


def test_a_tray_target_is_pinched_on_its_wall_and_carried_level_into_the_goal(grasps: GraspDB) -> None:
    """Task 17: a tray pinched on one wall and carried level (a free carry turned one 20° in the pinch)."""
    recipe = load_family_recipe("stack")
    task, probe = _kept_target_pick(grasps, recipe, 17, "tray/", "rim_", _TrayProbe)
    z0 = probe.rows[0][1]
    lifted = [row for row in probe.rows if row[1] > z0 + 0.02]
    assert len(lifted) > 50  # lifted 2 cm clear of the table for the carry and the hold
    assert all(fingers >= 1 and others == 0 for _, _, fingers, others in lifted)  # only the hand holds it
    assert sum(fingers == 2 for _, _, fingers, _ in lifted) >= 0.9 * len(lifted)  # in the pinch
    assert all(fingers == 2 for _, _, fingers, _ in lifted[-recipe.tasks.hold_steps:])
    assert max(tilt for tilt, _, _, _ in lifted) <= 10.0  # level (the bound), from raw xquat
    assert np.linalg.norm(probe.centre - np.asarray(task.goal.pos)) < task.goal.radius  # its box centre


# --- a chopping board as the target -------------------------------------------------------------------------
def _deepest(m: mujoco.MjModel, d: mujoco.MjData, a: int, b: int) -> float:
    """The deepest overlap (m, raw ``-data.contact.dist``) between geoms of bodies ``a`` and ``b``."""
    return max((-float(c.dist) for c in d.contact[:d.ncon]
                if {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])} == {a, b}), default=0.0)


class _BoardProbe(_TrayProbe):
    """The tray probe's rows, plus the board's near end (its smallest world x, from its box geom's corners,
    :func:`tests.helpers.rawdata.near_end`), its deepest overlap with the table (raw ``data.contact``) and
    whether the hand is closed (its finger bodies under 5 cm apart; open they are 8 cm) after every step."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.geom, self.table = m.geom("target/body").id, m.body("table").id
        self.finger_ids = [m.body(n).id for n in ("left_finger", "right_finger")]
        self.near_end: list[float] = []
        self.into_table: list[tuple[float, bool]] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        self.near_end.append(rawdata.near_end(m, d, self.geom))
        apart = float(np.linalg.norm(d.xpos[self.finger_ids[0]] - d.xpos[self.finger_ids[1]]))
        self.into_table.append((_deepest(m, d, self.body, self.table), apart < 0.05))


def test_a_board_target_is_pushed_over_the_back_edge_pinched_and_lifted_level_into_the_goal(
        grasps: GraspDB) -> None:
    """Task 1: a chopping board under three boxes. The boxes go to the pile, the board slides over the table's
    back edge and is held by a pinch of its overhang alone, level, in the goal."""
    task, probe = _kept_target_pick(grasps, load_family_recipe("stack"), 1, "board/", "edge_", _BoardProbe)
    assert probe.near_end[0] > TABLE_X[0]  # it starts lying wholly on the table
    z0 = probe.rows[0][1]
    leaves = next(i for i, row in enumerate(probe.rows) if row[1] > z0 + 0.005)
    assert probe.near_end[leaves] < TABLE_X[0]  # pushed over the edge before it leaves the table
    lifted = [row for row in probe.rows if row[1] > z0 + 0.02]
    assert len(lifted) > 50
    assert all(fingers == 2 and others == 0 for _, _, fingers, others in lifted)  # the pinch alone holds it
    assert max(tilt for tilt, _, _, _ in probe.rows) <= 10.0  # level all the way (the bound)
    assert np.linalg.norm(probe.centre - np.asarray(task.goal.pos)) < task.goal.radius
    # the pinch aims where the arm rests (mgdata.grasps.rest): aimed at the plain pose, the arm rested 5 mm
    # low, the upper finger met the board first and drove it 4.5 mm into the table's edge (task 9: 5.3 mm).
    # Closed on it, now 0.4 mm (the open hand's push presses its edge 0.8 mm into the table's: not counted)
    pinched = [depth for depth, closed in probe.into_table if closed]
    assert pinched and max(pinched) < 0.001, f"{max(pinched) * 1000:.2f} mm"
