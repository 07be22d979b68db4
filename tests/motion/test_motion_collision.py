"""The collision checker's rules: world margin, self-collision, gripper, allowed pairs, masks, relaxation."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.errors import SceneError
from mgdata.motion import NO_CONTACTS, AllowedContacts, Attachment, CheckConfig, MotionPlanner
from mgdata.motion.collision import CollisionChecker
from mgdata.sim.robot import FINGER_BODIES, HAND_BODY, HOME_Q, TCP_SITE, load_panda_spec, robot_body_ids
from tests.helpers.motion_scenes import down_pose, home_data


def probe_scene() -> mujoco.MjModel:
    """Panda + three boxes between the open fingers at HOME: colliding, non-colliding (0/0), other mask (2/2),
    plus a table with a loose cube resting on it."""
    spec = load_panda_spec()
    model = spec.compile()
    data = home_data(model)
    tcp = data.site_xpos[model.site(TCP_SITE).id].copy()
    for name, contype, conaffinity in (("solid", 1, 1), ("ghost", 0, 0), ("masked", 2, 2)):
        body = spec.worldbody.add_body(name=name, pos=tcp.tolist())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.06, 0.06, 0.03], contype=contype,
                      conaffinity=conaffinity)
    table = spec.worldbody.add_body(name="table", pos=[0.6, 0.0, -0.02])
    table.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.3, 0.3, 0.02])
    cube = spec.worldbody.add_body(name="cube", pos=[0.6, 0.2, 0.02])
    cube.add_freejoint()
    cube.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.02, 0.02])
    return spec.compile()


@pytest.fixture(scope="module")
def probe() -> tuple[mujoco.MjModel, CollisionChecker]:
    model = probe_scene()
    checker = CollisionChecker(model, CheckConfig())
    checker.sync(home_data(model))
    return model, checker


def test_only_pairs_that_collide_in_the_scene_are_reported(probe: tuple) -> None:
    _, checker = probe
    checker.configure(NO_CONTACTS, None, 0.0)
    found = checker.collisions(HOME_Q)
    assert found and {c.body2 for c in found} == {"solid"}  # ghost (0/0) and masked (2/2) never touch
    assert {c.body1 for c in found} <= {HAND_BODY, *FINGER_BODIES}
    checker.configure(AllowedContacts(((HAND_BODY, "solid"),)), None, 0.0)
    assert checker.valid(HOME_Q)  # "hand" covers the palm and both fingers


def test_world_contacts_are_not_even_generated(probe: tuple) -> None:
    model, checker = probe
    data = home_data(model)  # the cube rests on the table: the scene itself has that contact
    mujoco.mj_forward(model, data)
    cube = model.body("cube").id
    assert any(cube in (model.geom_bodyid[c.geom[0]], model.geom_bodyid[c.geom[1]]) for c in data.contact)
    checker.configure(AllowedContacts(((HAND_BODY, "solid"),)), None, 0.0)
    checker.valid(HOME_Q)
    bodies = {model.geom_bodyid[g] for g in checker.data.contact.geom.ravel()}
    assert cube not in bodies and model.body("table").id not in bodies


def test_self_collision_is_invalid_but_closed_fingers_are_fine() -> None:
    model = load_panda_spec().compile()
    checker = CollisionChecker(model, CheckConfig())
    data = home_data(model)
    data.qpos[7:9] = 0.0  # fingers closed: they touch each other
    checker.sync(data)
    checker.configure(NO_CONTACTS, None, 0.0)
    assert checker.valid(HOME_Q)
    robot = set(robot_body_ids(model).tolist())
    rng = np.random.default_rng(0)
    lo, hi = model.jnt_range[:7].T
    oracle = mujoco.MjData(model)
    for _ in range(400):
        q = rng.uniform(lo, hi)
        oracle.qpos[:7] = q
        mujoco.mj_kinematics(model, oracle)
        mujoco.mj_collision(model, oracle)
        hits = [(model.geom_bodyid[c.geom[0]], model.geom_bodyid[c.geom[1]]) for c in oracle.contact
                if c.dist < 0]
        self_hit = any(a in robot and b in robot and not {model.body(a).name, model.body(b).name} <= {
            HAND_BODY, *FINGER_BODIES} for a, b in hits)
        assert checker.valid(q) == (not self_hit)


def test_margin_inflates_and_relaxation_keeps_exact_pairs(planner: MotionPlanner) -> None:
    checker = planner.checker
    q = planner.ik(down_pose(0.6, 0.35, 0.015), HOME_Q, np.random.default_rng(0))
    checker.configure(NO_CONTACTS, None, 0.0)
    gap = min(d for d in _table_distances(checker, q))
    assert 0.0 < gap < 0.01  # fingertips just above the table
    assert checker.valid(q)
    checker.set_margin(0.01)
    assert not checker.valid(q) and "table" in checker.explain(q)
    checker.relax_pairs_at(q)
    assert checker.valid(q)  # the pair near at the query's start is judged exactly ...
    q_deeper = planner.ik(down_pose(0.6, 0.35, 0.0), HOME_Q, np.random.default_rng(0))
    assert not checker.valid(q_deeper)  # ... so real penetration is still caught


def _table_distances(checker: CollisionChecker, q: np.ndarray) -> list[float]:
    checker.set_margin(0.02)
    checker.valid(q)
    m, con = checker.model, checker.data.contact
    table = m.body("table").id
    out = [float(c.dist) for c in con if table in (m.geom_bodyid[c.geom[0]], m.geom_bodyid[c.geom[1]])]
    checker.set_margin(0.0)
    return out


def test_a_held_object_may_touch_the_gripper_but_nothing_else(wall_model: mujoco.MjModel) -> None:
    checker = CollisionChecker(wall_model, CheckConfig())
    data = home_data(wall_model)
    data.qpos[7:9] = 0.019  # fingers 2 mm into the 4 cm box
    tcp = data.site_xpos[wall_model.site(TCP_SITE).id]
    box_adr = wall_model.jnt_qposadr[wall_model.body("box").jntadr[0]]
    data.qpos[box_adr:box_adr + 3] = tcp
    checker.sync(data)
    checker.configure(NO_CONTACTS, None, 0.0)
    assert {c.body2 for c in checker.collisions(HOME_Q)} == {"box"}
    tcp_T_box = np.eye(4)
    tcp_T_box[:3, :3] = data.site_xmat[wall_model.site(TCP_SITE).id].reshape(3, 3).T  # box axis-aligned
    checker.configure(NO_CONTACTS, Attachment("box", tcp_T_box), 0.0)
    assert checker.valid(HOME_Q)
    tcp_T_box[2, 3] = 0.48  # the same box held 48 cm further down the approach axis: in the table
    checker.configure(NO_CONTACTS, Attachment("box", tcp_T_box), 0.0)
    assert "box <-> table" in checker.explain(HOME_Q)


def test_riders_move_with_the_held_object() -> None:
    """A tray lifted with a pebble on it: without the pebble as a rider the tray would sweep through it."""
    spec = load_panda_spec()
    table = spec.worldbody.add_body(name="table", pos=[0.6, 0.0, -0.02])
    table.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.4, 0.6, 0.02])
    for name, z, size in (("tray", 0.01, [0.05, 0.05, 0.01]), ("pebble", 0.03, [0.01, 0.01, 0.01])):
        body = spec.worldbody.add_body(name=name, pos=[0.5, 0.0, z])
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=size)
    model = spec.compile()
    mp = MotionPlanner(model)
    data = home_data(model)
    mp.sync(data)
    rng = np.random.default_rng(0)
    q_grip = mp.ik(down_pose(0.5, 0.0, 0.01), HOME_Q, rng)  # TCP at the tray's centre
    q_lift = mp.ik(down_pose(0.5, 0.0, 0.11), q_grip, rng)
    world_T_tray = np.eye(4)
    world_T_tray[:3, 3] = [0.5, 0.0, 0.01]
    tcp_T_tray = np.linalg.solve(mp.fk(q_grip).matrix(), world_T_tray)
    lifting = np.stack([q_grip, q_lift])
    allowed = AllowedContacts(((HAND_BODY, "tray"), (HAND_BODY, "pebble"), ("tray", "table")))
    mp.checker.configure(allowed, Attachment("tray", tcp_T_tray), 0.0)
    hit = mp.checker.first_invalid(lifting, 0.01)
    assert hit is not None and "tray <-> pebble" in mp.checker.explain(hit[1])
    mp.checker.configure(allowed, Attachment("tray", tcp_T_tray, riders=("pebble",)), 0.0)
    assert mp.checker.first_invalid(lifting, 0.01) is None
    pebble = mp.checker.data.xpos[model.body("pebble").id]
    np.testing.assert_allclose(pebble, [0.5, 0.0, 0.13], atol=2e-3)  # rode up 10 cm with the tray


def test_bad_names_are_scene_errors(planner: MotionPlanner) -> None:
    with pytest.raises(SceneError, match=r"AllowedContacts names body 'jarr'.*'box'"):
        planner.checker.configure(AllowedContacts((("hand", "jarr"),)), None, 0.0)
    with pytest.raises(SceneError, match="free joint"):
        planner.checker.configure(NO_CONTACTS, Attachment("wall"), 0.0)
    with pytest.raises(SceneError, match="'link7' must be a child of the world with a free joint"):
        planner.checker.configure(NO_CONTACTS, Attachment("link7"), 0.0)
