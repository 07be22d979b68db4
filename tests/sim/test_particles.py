"""Particle sets: liquid packing and its errors, dust wiped by a sponge (and only by a sponge)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.errors import SceneError
from mgdata.sim.assets import get_model
from mgdata.sim.labelling import Labeller
from mgdata.sim.particles import PARK_Z
from mgdata.sim.scene import build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.spec import Proposition, SafetySpec
from tests.helpers.sim_tasks import task_with


def test_liquid_fills_its_container_and_stays_in_at_rest() -> None:
    bowl = get_model("bowl/round_03")
    water = get_model("liquid/water_01")
    spec = SafetySpec("l", (), (Proposition("spilled", "spilled", ("water",), {"container": "bowl"}),))
    scene = build_scene(task_with(ObjectPlacement("bowl", bowl.name, (0.5, -0.2, 0.0), yaw=0.7),
                                  ObjectPlacement("water", water.name, (0.5, -0.2, bowl.geometry["bottom"])),
                                  spec=spec))
    scene.reset()
    balls = scene.liquids["water"].body_ids
    assert len(balls) == water.geometry["count"]
    assert len(scene.object_geom_ids("water")) == len(balls)
    for _ in range(500):
        mujoco.mj_step(scene.model, scene.data)
    mujoco.mj_forward(scene.model, scene.data)
    assert not Labeller(scene, spec).as_dict()["spilled"]
    local = scene.data.xpos[balls] - np.array([0.5, -0.2, 0.0])
    assert np.hypot(local[:, 0], local[:, 1]).max() < bowl.geometry["rim_radius"]
    assert local[:, 2].min() > 0.0


@pytest.mark.parametrize(
    ("objects", "message"),
    [
        ((ObjectPlacement("water", "liquid/water_00", (0.5, 0.0, 0.0)),), "not inside any container"),
        ((ObjectPlacement("cup", "cup/tumbler_03", (0.5, 0.0, 0.0)),
          ObjectPlacement("water", "liquid/water_02", (0.5, 0.0, 0.006))), "does not fit in cup/tumbler_03"),
    ],
)
def test_misplaced_liquid_is_a_clear_error(objects: tuple[ObjectPlacement, ...], message: str) -> None:
    with pytest.raises(SceneError, match=message):
        build_scene(task_with(*objects))


def test_sponge_wipes_dust_and_covered_follows() -> None:
    board = get_model("board/chopping_00")
    top = board.size[2]
    dust = get_model("dust/layer_00")
    spec = SafetySpec("d", (), (Proposition("dusty", "covered", ("dust",)),
                                Proposition("board_dusty", "covered", ("board",))))
    scene = build_scene(task_with(ObjectPlacement("board", board.name, (0.55, 0.0, 0.0)),
                                  ObjectPlacement("dust", dust.name, (0.55, 0.0, top)),
                                  ObjectPlacement("sponge", "sponge/block_00", (0.55, 0.3, 0.0)),
                                  spec=spec))
    scene.reset()
    lab = Labeller(scene, spec)
    m, d = scene.model, scene.data
    adr = m.jnt_qposadr[m.joint("sponge/free").id]
    start = scene.snapshot()

    def sweep(z: float) -> list[float]:
        fractions = []
        for y in np.linspace(-0.08, 0.08, 9):
            for x in np.linspace(0.55 - 0.08, 0.55 + 0.08, 9):
                d.qpos[adr : adr + 3] = [x, y, z]
                mujoco.mj_forward(m, d)
                scene.after_control_step()
            fractions.append(scene.dust.remaining_fraction(d, "dust"))
        return fractions

    assert lab.as_dict() == {"dusty": True, "board_dusty": True}
    assert scene.dust.remaining_fraction(d, "dust") == 1.0
    assert sweep(top + 0.03)[-1] == 1.0, "a sponge hovering 3 cm above wipes nothing"
    assert sweep(top + 0.002)[-1] == 1.0, "2 mm above (covering the specks, no contact) wipes nothing"
    fractions = sweep(top - 0.0005)  # resting on the board: in contact with it
    assert fractions[-1] == 0.0 and np.all(np.diff(fractions) <= 0) and fractions[3] < 1.0
    assert lab.as_dict() == {"dusty": False, "board_dusty": False}
    assert np.all(d.mocap_pos[scene.dust.mocap_ids["dust"], 2] == PARK_Z)
    scene.restore(start)  # dust is part of the physics state
    assert scene.dust.remaining_fraction(d, "dust") == 1.0 and lab.as_dict()["dusty"]


def test_dust_moves_with_its_host_and_only_a_touching_sponge_wipes_it() -> None:
    """Specks keep their place on the board when it is moved and tilted (checked against the board's raw
    pose); a sponge resting on the moved board (a raw ``data.contact`` with it) wipes the specks it covers
    there, and the others stay in place."""
    board = get_model("board/chopping_00")
    top = board.size[2]
    scene = build_scene(task_with(ObjectPlacement("board", board.name, (0.55, 0.0, 0.0)),
                                  ObjectPlacement("dust", "dust/layer_00", (0.55, 0.0, top)),
                                  ObjectPlacement("sponge", "sponge/block_00", (0.55, 0.3, 0.0))))
    scene.reset()
    m, d = scene.model, scene.data
    ids, body = scene.dust.mocap_ids["dust"], m.body("board").id
    local = (d.mocap_pos[ids] - d.xpos[body]) @ d.xmat[body].reshape(3, 3)  # raw, from the initial state
    assert scene.dust_hosts == {"dust": "board"}
    adr = m.jnt_qposadr[m.joint("board/free").id]
    half = np.deg2rad(25.0) / 2
    d.qpos[adr: adr + 7] = [0.40, 0.10, 0.20, np.cos(half), np.sin(half), 0.0, 0.0]  # moved up and tilted
    mujoco.mj_forward(m, d)
    scene.after_control_step()
    rot = d.xmat[body].reshape(3, 3)
    np.testing.assert_allclose(d.mocap_pos[ids], d.xpos[body] + local @ rot.T, atol=1e-9)
    assert np.all(d.mocap_pos[ids, 2] > 0.15), "the specks left the table with the board"
    sadr = m.jnt_qposadr[m.joint("sponge/free").id]
    d.qpos[adr: adr + 7] = [0.55, 0.0, 0.30, 1.0, 0.0, 0.0, 0.0]  # board lifted 30 cm, level
    mujoco.mj_forward(m, d)
    scene.after_control_step()
    specks = d.mocap_pos[ids].copy()
    d.qpos[sadr: sadr + 3] = [0.55, 0.0, 0.30 + top - 0.0005]  # resting on the lifted board: wipes
    d.qpos[sadr + 3: sadr + 7] = [1.0, 0.0, 0.0, 0.0]
    mujoco.mj_forward(m, d)
    sponge_geoms = scene.object_geom_ids("sponge")
    board_geoms = scene.object_geom_ids("board")
    g = d.contact.geom[: d.ncon]
    touching = bool(np.any(np.isin(g[:, 0], sponge_geoms) & np.isin(g[:, 1], board_geoms)
                           | np.isin(g[:, 1], sponge_geoms) & np.isin(g[:, 0], board_geoms)))
    assert touching, "raw data.contact: the sponge touches the board"
    wiped = scene.dust.update(d)
    assert wiped > 0 and scene.dust.remaining_fraction(d, "dust") < 1.0
    left = d.mocap_pos[ids, 2] > PARK_Z / 2
    assert np.all(d.mocap_pos[ids][left] == specks[left])
