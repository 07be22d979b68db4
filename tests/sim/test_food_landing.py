"""A candy poured into dusty's tray lands on its floor, not in it: judged from raw ``data.contact``.

The scene comes from mgdata's scene builder (so ``recipes/sim.toml``'s ``[contact]`` model): one of dusty's
destination trays on the table and one of its candies. Each candy is dropped tumbling (12 rad/s) from the
pour's release height: its lowest point ``pour_clearance`` above the tray's rim, as the pour holds the
carrier's outline (measured in generated demos: 3.6-4.9 cm above the floor, landing at 0.75-1.1 m/s). The
test steps raw ``mujoco.mj_step`` and after every physics step reads the deepest overlap ``-contact.dist``
among the candy, the tray and the table. A stiff contact still lets the candy travel one timestep into the
floor before MuJoCo finds it (``v · timestep``, 2.2 mm at 1.1 m/s); what must hold:

* no physics step deeper than ``STEP_BOUND`` (2.5 mm, one timestep at 1.25 m/s; over 30 drops at most
  2.0 mm); with MuJoCo's default contact (0.02 s) the candy sank 5.9-7.4 mm into the 6 mm floor;
* never more than ``RUN_BOUND`` (4) consecutive steps deeper than 1 mm, so a 20 Hz frame (every 25th step)
  rarely sees more than the gate's 1 mm (at most 3 over 30 drops; with the default contact 27-46);
* at rest the candy sits on the floor, not in it: its lowest corner at most ``REST_BOUND`` (0.05 mm; 0.01 mm
  measured, 0.11 mm with the default contact) below the floor's top.
"""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest

from mgdata.sim.assets import get_model
from mgdata.sim.scene import build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.skeleton.skeleton import load_family_recipe
from tests.helpers.sim_tasks import task_with

STEP_BOUND = 0.0025
RUN_BOUND = 4
REST_BOUND = 0.00005
SPIN = 12.0  # rad/s, about a random axis (the candies leave the carrier tumbling at 7-18 rad/s)
STEPS = 500  # 1 s: falling 0.1 s, then settling
TRAY = (0.5, 0.25)


def _role_models(name: str) -> tuple[str, ...]:
    return next(r.models for r in load_family_recipe("dusty").layout.roles if r.name == name)


def _drop(tray: str, food: str, seed: int) -> tuple[np.ndarray, float, float]:
    """Drop ``food`` into ``tray``: the deepest candy/tray/table overlap after every physics step (m), and at
    the end the candy's lowest point and the tray floor's top (m)."""
    task = task_with(ObjectPlacement("dest", tray, (*TRAY, 0.0)),
                     ObjectPlacement("food", food, (0.3, -0.3, 0.0)))  # moved over the tray below
    scene = build_scene(task)
    m, d = scene.model, scene.data
    bottom = float(get_model(tray).geometry["bottom"])
    release = float(get_model(tray).size[2]) + float(load_family_recipe("dusty").params["pour_clearance"])
    rng = np.random.default_rng(seed)
    food_body = m.body("food").id
    joint = m.body_jntadr[food_body]
    qpos, dof = m.jnt_qposadr[joint], m.jnt_dofadr[joint]
    quat = rng.normal(size=4)
    d.qpos[qpos:qpos + 3] = [TRAY[0] + rng.uniform(-0.05, 0.05), TRAY[1] + rng.uniform(-0.03, 0.03), 0.2]
    d.qpos[qpos + 3:qpos + 7] = quat / np.linalg.norm(quat)
    d.qvel[dof:dof + 6] = 0.0
    axis = rng.normal(size=3)
    d.qvel[dof + 3:dof + 6] = SPIN * axis / np.linalg.norm(axis)
    mujoco.mj_forward(m, d)
    geom = next(g for g in range(m.ngeom) if m.geom_bodyid[g] == food_body)
    d.qpos[qpos + 2] += release - _lowest(m, d, geom)
    mujoco.mj_forward(m, d)
    roots = {food_body, m.body("dest").id, m.body("table").id}
    deepest = np.zeros(STEPS)
    for k in range(STEPS):
        mujoco.mj_step(m, d)
        for c in d.contact[:d.ncon]:
            pair = {int(m.body_rootid[m.geom_bodyid[c.geom1]]), int(m.body_rootid[m.geom_bodyid[c.geom2]])}
            if pair <= roots:
                deepest[k] = max(deepest[k], -c.dist)
    floor = m.geom("dest/bottom").id
    floor_top = float(d.geom_xpos[floor, 2] + m.geom_size[floor, 2])
    assert abs(floor_top - bottom) < 0.001  # the tray still stands on the table
    return deepest, _lowest(m, d, geom), floor_top


def _lowest(m: mujoco.MjModel, d: mujoco.MjData, geom: int) -> float:
    """Height of the lowest corner of box ``geom``."""
    rot, half = d.geom_xmat[geom].reshape(3, 3), m.geom_size[geom]
    return min(float((d.geom_xpos[geom] + rot @ (np.array(s) * half))[2])
               for s in itertools.product((-1.0, 1.0), repeat=3))


def _longest_run(flags: np.ndarray) -> int:
    run = best = 0
    for f in flags:
        run = run + 1 if f else 0
        best = max(best, run)
    return best


@pytest.mark.parametrize("seed", range(3))
def test_a_poured_candy_lands_on_the_trays_floor_not_in_it(seed: int) -> None:
    trays, foods = _role_models("dest"), ("food/candy_01", "food/candy_05", "food/candy_06")
    tray, food = trays[seed % len(trays)], foods[seed]
    for drop in range(2):
        deepest, low, floor_top = _drop(tray, food, 10 * seed + drop)
        where = f"{food} into {tray}, drop {10 * seed + drop}"
        assert deepest.max() <= STEP_BOUND, f"{where}: {deepest.max() * 1000:.2f} mm deep at step " \
                                            f"{int(deepest.argmax())}"
        assert _longest_run(deepest > 0.001) <= RUN_BOUND, \
            f"{where}: {_longest_run(deepest > 0.001)} consecutive physics steps deeper than 1 mm"
        assert low >= floor_top - REST_BOUND, \
            f"{where}: at rest its lowest corner is {(floor_top - low) * 1000:.2f} mm below the floor's top"
