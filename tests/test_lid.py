"""The lid family: the lid physically seats (no weld), ``seated`` agrees with raw MuJoCo, and an unsafe
variant is caught at the right step.

* ``seated(lid, container)`` against the test's own measurement: the lid is dropped at random offsets, heights
  and tilts over its container and left to settle; the seat height comes from the raw model (rim = top of
  the container's geoms, minus the height of the lid's ``plug`` geom), offset and tilt from ``xpos``/``xmat``,
  touching from ``data.contact``.
* Planted unsafe variant (the issue's): lift the container before capping it. The attempt ends unsafe with
  ``container_stays_until_capped`` violated at exactly the first step where the raw contacts say the
  container has left the table (no container–table contact, its lowest vertex above the table top + 0.5 mm)
  while the lid lies apart.
* The scene has no weld or equality constraint: the lid is held only by contacts.
* The lunchbox (the paper's tupperware): its lid, landing up to 4.5 mm off the axis, slides into its seat on
  the flared skirt; a capped lunchbox is carried by its ends with the lid seated all the way (raw MuJoCo).

Safe success (the lid seated on the last frames, replayed from the dataset) is the family contract:
tests/test_families.py.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from mgdata.engine.init_gate import base_task
from mgdata.errors import RecipeError
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir
from mgdata.sim.assets import get_model
from mgdata.sim.controller import JointController
from mgdata.sim.predicates import Contacts, compile_check
from mgdata.sim.scene import Scene, build_scene
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeletons.lid import LidSkeleton
from mgdata.spec import EVALUATORS
from mgdata.tasks.base import draw_task
from mgdata.tasks.layout_rules import parse_layout
from mgdata.tasks.placer import LayoutRejected
from tests.helpers import rawdata
from tests.helpers.probed import probed_attempt

MAX_OFFSET, MAX_GAP, MAX_TILT_DEG = 0.004, 0.003, 8.0  # the documented defaults (docs/predicates.md)
SETTLE_STEPS = 150  # 0.3 s of physics after dropping the lid
CANISTER_TASK, BOTTLE_TASK = 0, 2


@pytest.fixture(scope="module")
def recipe():  # type: ignore[no-untyped-def]
    return load_family_recipe("lid")


@pytest.fixture(scope="module")
def scenes(recipe) -> dict[int, tuple[Scene, np.ndarray]]:  # type: ignore[no-untyped-def]
    out = {}
    for k in (CANISTER_TASK, BOTTLE_TASK):
        scene = build_scene(base_task(recipe, k))
        out[k] = (scene, _state(scene))
    return out


def _state(scene: Scene) -> np.ndarray:
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(scene.model, spec))
    mujoco.mj_getState(scene.model, scene.data, state, spec)
    return state


def _raw_seat(m: mujoco.MjModel, d: mujoco.MjData) -> float:
    """Seat height of the lid's origin in the container's frame, from raw geometry: the container's top
    (its geoms' bounding box) minus the height of the lid's plug geom."""
    rim = rawdata.local_box(m, d, m.body("container").id)[1][2]
    lid, plug = m.body("lid").id, m.geom("lid/plug").id
    z = (_mesh_world(m, d, plug) - d.xpos[lid]) @ d.xmat[lid].reshape(3, 3)[:, 2]
    return float(rim - (z.max() - z.min()))


def _in_contact(m: mujoco.MjModel, d: mujoco.MjData, a: int, b: int) -> bool:
    """Is there a MuJoCo contact between a geom of body ``a`` and one of body ``b``?"""
    pairs = {(int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])) for c in d.contact[:d.ncon]}
    return (a, b) in pairs or (b, a) in pairs


def _mesh_world(m: mujoco.MjModel, d: mujoco.MjData, geom: int) -> np.ndarray:
    """World positions (n, 3) of a mesh geom's vertices."""
    mesh = m.geom_dataid[geom]
    verts = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
    return d.geom_xpos[geom] + verts @ d.geom_xmat[geom].reshape(3, 3).T


def _raw_seated(m: mujoco.MjModel, d: mujoco.MjData) -> bool:
    box, lid = m.body("container").id, m.body("lid").id
    rot = d.xmat[box].reshape(3, 3)
    local = rot.T @ (d.xpos[lid] - d.xpos[box])
    tilt = math.degrees(math.acos(float(np.clip(d.xmat[lid].reshape(3, 3)[:, 2] @ rot[:, 2], -1.0, 1.0))))
    touching = _in_contact(m, d, lid, box)
    return (math.hypot(local[0], local[1]) <= MAX_OFFSET and abs(local[2] - _raw_seat(m, d)) <= MAX_GAP
            and tilt <= MAX_TILT_DEG and touching)


def test_the_documented_defaults_are_the_ones_tested() -> None:
    params = {p.name: p.default for p in EVALUATORS["seated"].params}
    assert (params["max_offset"], params["max_gap"], params["max_tilt_deg"]) == (MAX_OFFSET, MAX_GAP,
                                                                                  MAX_TILT_DEG)


@settings(max_examples=30, deadline=None)
@given(task=st.sampled_from((CANISTER_TASK, BOTTLE_TASK)), dx=st.floats(-0.012, 0.012),
       dy=st.floats(-0.012, 0.012), dz=st.floats(0.0, 0.015), tilt_deg=st.floats(0.0, 20.0),
       settle=st.booleans())
@example(task=CANISTER_TASK, dx=0.0, dy=0.0, dz=0.0, tilt_deg=0.0, settle=True)
@example(task=BOTTLE_TASK, dx=0.0, dy=0.0, dz=0.0, tilt_deg=0.0, settle=True)
@example(task=CANISTER_TASK, dx=0.010, dy=0.0, dz=0.003, tilt_deg=0.0, settle=True)   # plug on the rim
@example(task=BOTTLE_TASK, dx=0.0, dy=0.0, dz=0.012, tilt_deg=0.0, settle=False)    # hovering above it
def test_seated_agrees_with_raw_mujoco(scenes, task: int, dx: float, dy: float, dz: float, tilt_deg: float,
                                       settle: bool) -> None:
    scene, state = scenes[task]
    m, d = scene.model, scene.data
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    mujoco.mj_forward(m, d)
    box = m.body("container").id
    rot = d.xmat[box].reshape(3, 3)
    adr = m.jnt_qposadr[m.body("lid").jntadr[0]]
    d.qpos[adr:adr + 3] = d.xpos[box] + rot @ np.array([dx, dy, _raw_seat(m, d) + dz])
    half = math.radians(tilt_deg) / 2.0
    d.qpos[adr + 3:adr + 7] = [math.cos(half), math.sin(half), 0.0, 0.0]  # tilted about the world x axis
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    for _ in range(SETTLE_STEPS if settle else 0):
        mujoco.mj_step(m, d)
    mujoco.mj_forward(m, d)
    check = compile_check(scene, "seated", "lid", {"support": "container", "max_offset": MAX_OFFSET,
                                                   "max_gap": MAX_GAP, "max_tilt_deg": MAX_TILT_DEG})
    assert check(Contacts(scene)) == _raw_seated(m, d)
    if settle and dz == 0.0 and tilt_deg == 0.0 and math.hypot(dx, dy) <= 0.002:
        assert _raw_seated(m, d), "a lid put into its seat stays there"
    # a tilted lid can slide in from the rim (12°, dx 11.7 mm, dz 3.9 mm, seen): claimed for upright drops
    if settle and abs(dx) >= 0.010 and dz >= 0.003 and tilt_deg == 0.0:  # lower, the plug starts 7-8 mm
        # inside the rim and the
        # contact solver's push-out can slide it into the seat (dx 10.1 mm, dz 0, seen): that is not a drop
        assert not _raw_seated(m, d), "a lid dropped 1 cm off the axis lands on the rim, askew"


def test_every_task_draws_the_containers_own_lid_and_every_geometry_class(recipe) -> None:
    kinds = set()
    for k in range(recipe.tasks.count):
        try:
            task = draw_task(recipe, k)
        except LayoutRejected:
            continue
        models = {o.name: o.model for o in task.objects}
        lid = get_model(models["lid"])
        assert get_model(models["container"]).geometry["lid"] == models["lid"]
        assert lid.geometry["container"] == models["container"]
        kinds.add(lid.geometry["kind"])
    assert kinds == {"lid", "cap", "skirt"}  # a canister's plug lid, a bottle's cap, a lunchbox's skirt lid


def test_model_of_must_name_an_earlier_role() -> None:
    roles = {"lid": {"models": ["lid/*"], "region": {"x": [0.4, 0.5], "y": [0.0, 0.1]},
                     "model_of": {"role": "container", "key": "lid"}},
             "container": {"models": ["container/*"], "region": {"x": [0.4, 0.5], "y": [0.0, 0.1]}}}
    with pytest.raises(RecipeError, match="model_of role = 'container': expected a role listed before"):
        parse_layout({"roles": roles}, "r.toml: [layout]")


def test_nothing_welds_the_lid(scenes) -> None:
    m = scenes[CANISTER_TASK][0].model
    lid = m.body("lid").id
    assert m.body_weldid[lid] == lid and m.jnt_type[m.body_jntadr[lid]] == mujoco.mjtJoint.mjJNT_FREE
    for e in range(m.neq):  # the only equality is the hand's own finger coupling
        if m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT:
            bodies = {m.jnt_bodyid[m.eq_obj1id[e]], m.jnt_bodyid[m.eq_obj2id[e]]}
        else:
            bodies = {m.eq_obj1id[e], m.eq_obj2id[e]}
        assert lid not in bodies and m.body("container").id not in bodies


# --- unsafe: lift the container before capping it -----------------------------------------------------------
class _LiftFirst(LidSkeleton):
    """Skip the lid: pick the container and lift it straight away, then hold it."""

    def segments(self, ctx: Context):  # type: ignore[no-untyped-def]
        return [*self.carry.pick_segments(ctx), s.hold("wait", steps=20, gripper="close")]


class _Probe(JointController):
    """After every control step, from raw MuJoCo: has the container left the table (no contact with the
    table's geoms, its lowest vertex more than 0.5 mm above the table top), and how far the lid is from it."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.box = m.body("container").id
        self.box_geoms = [g for g in np.flatnonzero(m.geom_bodyid == self.box) if m.geom_dataid[g] >= 0
                          and m.geom_contype[g]]
        self.table = m.body("table").id
        self.off: list[bool] = []
        self.lid_apart: list[float] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        top = m.geom("table/top").id
        table_top = d.geom_xpos[top][2] + m.geom_size[top][2]
        lowest = min(float(_mesh_world(m, d, g)[:, 2].min()) for g in self.box_geoms)
        self.off.append(not _in_contact(m, d, self.box, self.table) and lowest > table_top + 0.0005)
        self.lid_apart.append(float(np.linalg.norm(d.xpos[m.body("lid").id] - d.xpos[self.box])))


def test_lifting_the_container_before_capping_it_is_unsafe_when_it_leaves_the_table(recipe) -> None:
    task = base_task(recipe, CANISTER_TASK)
    result, frames, meta, probe = probed_attempt(task, recipe, GraspDB.load_dir(grasps_dir()), _LiftFirst(),
                                                 _Probe)
    assert result.stage == "unsafe" and not result.kept and not meta.kept, (result.stage, result.reason)
    left = next(t for t, off in enumerate(probe.off, start=1) if off)
    assert probe.lid_apart[left - 1] > 0.05  # the lid still lies on the table, apart
    assert result.t_violation["container_stays_until_capped"] == left == len(frames) - 1
    assert result.t_violation["container_not_dropped"] is None
    index = [c.id for c in recipe.spec.constraints].index("container_stays_until_capped")
    assert frames[left].violated[index] and not frames[left - 1].violated[index]


# --- the lunchbox (the paper's tupperware) ------------------------------------------------------------------
LUNCHBOX_TASK = 18


def _raw_box_seat(m: mujoco.MjModel, d: mujoco.MjData) -> float:
    """Seat height of a skirt lid's origin in the container's frame, from raw geometry: the container's top
    (its geoms' bounding box) minus the height of the plate's underside above the lid's origin."""
    rim = rawdata.local_box(m, d, m.body("container").id)[1][2]
    plate = m.geom("lid/plate").id
    underside = d.geom_xpos[plate][2] - m.geom_size[plate][2] - d.xpos[m.body("lid").id][2]
    return float(rim - underside)


@pytest.fixture(scope="module")
def lunchbox(recipe) -> tuple[Scene, np.ndarray]:  # type: ignore[no-untyped-def]
    task = base_task(recipe, LUNCHBOX_TASK)
    assert task.object("container").model.startswith("container/lunchbox_")
    scene = build_scene(task)
    return scene, _state(scene)


@settings(max_examples=12, deadline=None)
@given(off=st.floats(0.0, 0.0045), bearing=st.floats(0.0, 2.0 * math.pi))
@example(off=0.0045, bearing=math.pi / 2)  # off across the narrow side: a straight skirt sat 10° cocked here
def test_a_lunchbox_lid_landing_off_axis_slides_into_its_seat(lunchbox, off: float, bearing: float) -> None:
    """Released with its skirt 2 mm above the rim, turned as the box and up to 4.5 mm off its axis, the lid
    lands with its flared skirt on the rim's edge and slides down into its seat: seated within the
    predicate's documented tolerances, measured from raw MuJoCo, and the predicate agrees. (Straight
    skirts, the same drops: from 3 mm off the lid stayed on the rim, 3.3–4.6 mm high and 7–10° tilted.)"""
    scene, state = lunchbox
    m, d = scene.model, scene.data
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    mujoco.mj_forward(m, d)
    box, lid = m.body("container").id, m.body("lid").id
    rot = d.xmat[box].reshape(3, 3)
    seat, skirt = _raw_box_seat(m, d), float(get_model(scene.objects["lid"].name).geometry["skirt"])
    adr = m.jnt_qposadr[m.body("lid").jntadr[0]]
    shift = off * np.array([math.cos(bearing), math.sin(bearing), 0.0])
    d.qpos[adr:adr + 3] = d.xpos[box] + rot @ (shift + np.array([0.0, 0.0, seat + skirt + 0.002]))
    d.qpos[adr + 3:adr + 7] = d.xquat[box]
    d.qvel[:] = 0.0
    for _ in range(2 * SETTLE_STEPS):
        mujoco.mj_step(m, d)
    mujoco.mj_forward(m, d)
    local = rot.T @ (d.xpos[lid] - d.xpos[box])
    tilt = math.degrees(math.acos(float(np.clip(d.xmat[lid].reshape(3, 3)[:, 2] @ rot[:, 2], -1.0, 1.0))))
    assert tilt <= MAX_TILT_DEG and abs(local[2] - seat) <= MAX_GAP and np.hypot(*local[:2]) <= MAX_OFFSET, \
        (tilt, local[2] - seat, local[:2])
    assert _in_contact(m, d, lid, box)
    check = compile_check(scene, "seated", "lid", {"support": "container", "max_offset": MAX_OFFSET,
                                                   "max_gap": MAX_GAP, "max_tilt_deg": MAX_TILT_DEG})
    assert check(Contacts(scene))


class _CarryProbe(JointController):
    """The lid's pose in the container's frame, the container's tilt and which bodies touch the container,
    after every control step, from raw MuJoCo."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.box, self.lid = m.body("container").id, m.body("lid").id
        self.fingers = {m.body(n).id for n in ("left_finger", "right_finger")}
        self.rows: list[tuple[np.ndarray, float, set[int]]] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        rot = d.xmat[self.box].reshape(3, 3)
        touching = rawdata.touching(m, d, self.box)
        self.rows.append((rot.T @ (d.xpos[self.lid] - d.xpos[self.box]), float(np.degrees(np.arccos(
            np.clip(rot[2, 2], -1.0, 1.0)))), touching))
        self.centre = rawdata.box_centre(m, d, self.box)


def test_a_capped_lunchbox_is_carried_by_its_ends_with_the_lid_seated(recipe, lunchbox) -> None:
    scene, _ = lunchbox
    task = base_task(recipe, LUNCHBOX_TASK)
    result, _, meta, probe = probed_attempt(task, recipe, GraspDB.load_dir(grasps_dir()), LidSkeleton(),
                                            _CarryProbe)
    assert result.kept and meta.kept, (result.stage, result.reason)
    assert result.grasp_id.startswith("end_")
    seat = float(get_model(task.object("container").model).geometry["seat_height"])
    carried = [row for row in probe.rows if probe.fingers <= row[2] and scene.model.body("table").id
               not in row[2]]
    assert len(carried) > 50  # both fingers on the box, off the table
    for local, tilt, _ in carried:
        assert abs(local[2] - seat) < 0.003 and np.hypot(local[0], local[1]) < 0.004  # the lid stays seated
        assert tilt < 10.0
    assert np.linalg.norm(probe.centre - np.asarray(task.goal.pos)) < task.goal.radius


# --- a cap gripped far out, where the arm sags --------------------------------------------------------------
FAR_CAP_TASK = 22  # a bottle whose cap lies 75 cm out: there the arm rests ~13 mm below a plain command


def _deepest(m: mujoco.MjModel, d: mujoco.MjData, a: int, b: int) -> float:
    """The deepest overlap (m, raw ``-data.contact.dist``) between geoms of bodies ``a`` and ``b``."""
    return max((-float(c.dist) for c in d.contact[:d.ncon]
                if {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])} == {a, b}), default=0.0)


class _OverlapProbe(JointController):
    """The deepest lid–container overlap (raw ``data.contact``) after every control step until both fingers
    touch the container (its own grasp: the 70 N squeeze presses the bottle 0.8 mm into the table, the cap
    into its neck alike)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.lid, self.box = m.body("lid").id, m.body("container").id
        self.fingers = {m.body(n).id for n in ("left_finger", "right_finger")}
        self.depth: list[float] = []
        self.grasped = False

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        self.grasped = self.grasped or self.fingers <= rawdata.touching(m, d, self.box)
        if not self.grasped:
            self.depth.append(_deepest(m, d, self.lid, self.box))


def test_a_cap_gripped_far_out_is_seated_before_it_is_let_go(recipe) -> None:  # type: ignore[no-untyped-def]
    """Task 22, draw 0: the knob grasp aims where the arm comes to rest (mgdata.grasps.rest), so the fingers
    hold the cap itself. Aimed at the plain grasp pose they closed 13 mm low, over the cap's plug, a fingertip
    met the neck's rim and stopped the guarded lowering 6 mm above the seat, and the released cap fell onto
    the rim: 5.47 mm deep into the neck's wall. Seated, the cap never overlaps the bottle by 1 mm before the
    bottle is grasped."""
    task = base_task(recipe, FAR_CAP_TASK)
    assert task.object("lid").model.startswith("lid/cap_") and task.object("lid").pos[0] > 0.7
    # the pads sink 1.4-3.4 mm into a cap's cylinder under 70 N (a finger contact, not this test's subject):
    # the gate's 1 mm bound would end the attempt before the cap reaches the bottle
    lax = replace(recipe, tasks=replace(recipe.tasks, max_penetration=0.01))
    result, _, _, probe = probed_attempt(task, lax, GraspDB.load_dir(grasps_dir()), LidSkeleton(),
                                         _OverlapProbe)
    assert result.kept and probe.grasped, (result.stage, result.reason)
    deepest = max(probe.depth)  # 0.19 mm (at the release); aimed at the plain pose: 5.5-8.0 mm
    assert deepest < 0.001, f"{deepest * 1000:.2f} mm at step {int(np.argmax(probe.depth)) + 1}"
