"""Restarts of the phased families (issue 43): a demonstration started where a phase's postcondition already
holds skips that phase (lid: seated → no cap; dusty: tray clean → no wipe; cabinet: target in the open
drawer → only the close).

Each restart state is made in raw MuJoCo from the task's initial state (a free joint, a slide or the dust's
mocap bodies set, then the scene stepped until it rests), and every check is made from raw MuJoCo (body
positions, joint positions, mocap positions, ``data.contact``), not with the restart code.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task, cached_grasp_db
from mgdata.paths import grasps_dir
from mgdata.record.episode import MemorySink
from mgdata.record.physics import physics_state, set_physics_state
from mgdata.sim.particles import PARK_Z
from mgdata.skeleton.skeleton import load_family_recipe
from tests.helpers.rawdata import hand_touches

PARKED = PARK_Z / 2
"""Below this height a dust speck has been wiped (the scene parks wiped specks at ``PARK_Z``, 10 m under the
floor)."""


@pytest.fixture
def executor() -> Iterator[Callable[[str, int], Executor]]:
    made: list[Executor] = []

    def make(family: str, task_id: int) -> Executor:
        recipe = load_family_recipe(family)
        made.append(Executor(base_task(recipe, task_id), recipe, grasps=cached_grasp_db(grasps_dir()),
                             render=False))
        made[-1].scene.reset()
        return made[-1]

    yield make
    for ex in made:
        ex.close()


def _free_joint(m: mujoco.MjModel, body: str) -> tuple[int, int]:
    joint = m.body_jntadr[m.body(body).id]
    return int(m.jnt_qposadr[joint]), int(m.jnt_dofadr[joint])


def _lowest(m: mujoco.MjModel, d: mujoco.MjData, body: str) -> float:
    """The lowest corner of the world-aligned boxes of ``body``'s colliding geoms (m)."""
    geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body(body).id and m.geom_contype[g]]
    lows = []
    for g in geoms:
        rot, half = d.geom_xmat[g].reshape(3, 3), m.geom_aabb[g, 3:]
        centre = d.geom_xpos[g] + rot @ m.geom_aabb[g, :3]
        lows.append(centre[2] - float(np.abs(rot[2]) @ half))
    return min(lows)


def _settle(ex: Executor, seconds: float = 2.0) -> np.ndarray:
    m, d = ex.scene.model, ex.scene.data
    mujoco.mj_forward(m, d)
    for _ in range(int(seconds / m.opt.timestep)):
        mujoco.mj_step(m, d)
    return physics_state(m, d)


def _touched(m: mujoco.MjModel, d: mujoco.MjData) -> set[str]:
    """The root bodies the hand's geoms touch."""
    return {m.body(m.body_rootid[b]).name for b in hand_touches(m, d)}


def _restart(ex: Executor, start: np.ndarray, phases: list[str]) -> list[np.ndarray]:
    """Restart from ``start``; it must be kept, start there and run ``phases``; its physics states."""
    m, d = ex.scene.model, ex.scene.data
    set_physics_state(m, d, start)
    mujoco.mj_forward(m, d)
    assert not _touched(m, d), "the restart state has a free hand"
    sink = MemorySink()
    result = ex.run(0, sink, start=start, origin={"step": 0}, source="correction")
    assert result.kept, (result.stage, result.reason)
    frames, meta = sink.episodes[0]
    assert meta.variation["restart"]["phases"] == phases
    assert np.array_equal(frames[0].physics_state, start)
    return [f.physics_state for f in frames]


@pytest.mark.parametrize("task_id", [0, 2])  # a canister's lid, a bottle's cap
def test_lid_seated_runs_only_the_carry(executor, task_id: int) -> None:  # type: ignore[no-untyped-def]
    ex = executor("lid", task_id)
    m, d = ex.scene.model, ex.scene.data
    cont = m.body("container").id
    seat = float(ex.scene.object_model("container").geometry["seat_height"])

    def above_seat() -> float:  # the lid's frame above the container's seat, along the container's axis
        axis = d.xmat[cont].reshape(3, 3)[:, 2]
        return float((d.xpos[m.body("lid").id] - d.xpos[cont]) @ axis) - seat

    rot = d.xmat[cont].reshape(3, 3)
    yaw = np.arctan2(rot[1, 0], rot[0, 0])
    q, v = _free_joint(m, "lid")
    d.qpos[q:q + 3] = d.xpos[cont] + rot[:, 2] * (seat + 0.002)  # on the seat, turned as the container
    d.qpos[q + 3:q + 7] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    d.qvel[v:v + 6] = 0.0
    start = _settle(ex)
    assert abs(above_seat()) < 0.002
    touched, seated = set(), []
    for state in _restart(ex, start, ["carry"]):
        set_physics_state(m, d, state)
        touched |= _touched(m, d)
        seated.append(abs(above_seat()))
    assert "lid" not in touched, "no cap: the hand never touches the lid"
    assert "container" in touched, "the carry grasps the container"
    assert max(seated) < 0.003, "the lid rides seated throughout"
    goal = np.asarray(ex.task.goal.pos)
    assert np.linalg.norm(d.xipos[cont] - goal) < ex.task.goal.radius + 0.03  # carried there


def test_dusty_clean_tray_runs_only_the_pour(executor) -> None:  # type: ignore[no-untyped-def]
    ex = executor("dusty", 0)
    m, d = ex.scene.model, ex.scene.data
    specks = [int(m.body_mocapid[b]) for b in range(m.nbody) if m.body(b).name.startswith("dust/d")]
    assert specks and all(d.mocap_pos[specks, 2] > 0.0)  # dusty at the start
    d.mocap_pos[specks, 2] = PARK_Z  # wiped: every speck parked under the floor
    start = physics_state(m, d)
    touched = set()
    for state in _restart(ex, start, ["pour"]):
        set_physics_state(m, d, state)
        touched |= _touched(m, d)
        assert all(d.mocap_pos[specks, 2] < PARKED)  # stays clean
    assert "sponge" not in touched, "no wipe: the hand never touches the sponge"
    assert "source" in touched, "the pour grasps the source"
    dest = m.body("dest").id
    local = d.xmat[dest].reshape(3, 3).T @ (d.xpos[m.body("food").id] - d.xpos[dest])
    size = np.asarray(ex.scene.object_model("dest").size)
    assert np.all(np.abs(local[:2]) < size[:2] / 2) and -0.01 < local[2] < size[2] + 0.02  # poured in


def test_cabinet_target_in_the_open_drawer_runs_only_the_close(executor) -> None:  # type: ignore[no-untyped-def]
    ex = executor("cabinet", 0)
    m, d = ex.scene.model, ex.scene.data
    geo = ex.scene.object_model("cabinet").geometry
    slide = m.jnt_qposadr[m.joint("cabinet/drawer_slide").id]
    stroke = 0.6 * geo["travel"]
    d.qpos[slide] = stroke
    mujoco.mj_forward(m, d)
    drawer = m.body("cabinet/drawer").id
    rot = d.xmat[drawer].reshape(3, 3)
    inner = np.asarray(geo["drawer_inner"])
    x = (geo["half_extents"][0] - stroke + inner[0]) / 2  # the middle of the drawer's exposed part
    floor = d.xpos[drawer] + rot @ np.array([x, 0.0, geo["drawer_floor_z"] - m.body_pos[drawer][2]])
    q, v = _free_joint(m, "target")
    d.qpos[q:q + 3] = floor + np.array([0.0, 0.0, 0.05])
    d.qvel[v:v + 6] = 0.0
    mujoco.mj_forward(m, d)
    d.qpos[q + 2] += floor[2] + 0.003 - _lowest(m, d, "target")  # standing 3 mm above the drawer's floor
    start = _settle(ex)
    touched = set()
    for state in _restart(ex, start, ["close"]):
        set_physics_state(m, d, state)
        touched |= _touched(m, d)
    assert "target" not in touched, "no place: the hand never touches the target"
    assert "cabinet" in touched, "the close drives the handle"
    assert d.qpos[slide] < 0.05 * geo["travel"]  # shut
    local = d.xmat[drawer].reshape(3, 3).T @ (d.xpos[m.body("target").id] - d.xpos[drawer])
    assert np.all(np.abs(local[:2]) < inner[:2])  # still in the drawer
