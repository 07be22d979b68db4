"""Free-space motion: OMPL around a wall, toppra limits, exact recheck, allowed contacts, held objects."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.motion import NO_CONTACTS, AllowedContacts, Attachment, MotionConfig, MotionFailure, MotionPlanner
from mgdata.sim.robot import FINGER_BODIES, HAND_BODY, HOME_Q, robot_body_ids
from tests.helpers.motion_scenes import BOX_HALF, WALL_HALF, down_pose, home_data

WALL_TOP = 2 * WALL_HALF[2]


def penetrations(model: mujoco.MjModel, data: mujoco.MjData, path: np.ndarray, step: float = 0.005) -> list:
    """Oracle: (sample index, body, body, dist) of every penetrating contact involving the robot along the
    polyline ``path`` checked every ``step`` rad, contacts within the gripper excepted."""
    robot = set(robot_body_ids(model).tolist())
    gripper = {model.body(n).id for n in (HAND_BODY, *FINGER_BODIES)}
    d = mujoco.MjData(model)
    d.qpos[:] = data.qpos
    found = []
    for i in range(1, len(path)):
        n = max(1, int(np.ceil(np.max(np.abs(path[i] - path[i - 1])) / step)))
        for k in range(n + 1):
            d.qpos[:7] = path[i - 1] + (path[i] - path[i - 1]) * k / n
            mujoco.mj_kinematics(model, d)
            mujoco.mj_collision(model, d)
            for c in d.contact[: d.ncon] if d.ncon else []:
                b1, b2 = model.geom_bodyid[c.geom[0]], model.geom_bodyid[c.geom[1]]
                if c.dist < 0 and (b1 in robot or b2 in robot) and not (b1 in gripper and b2 in gripper):
                    found.append((i, model.body(b1).name, model.body(b2).name, float(c.dist)))
    return found


@pytest.fixture(scope="module")
def sides(planner: MotionPlanner) -> tuple[np.ndarray, np.ndarray]:
    """Top-down configurations 15 cm above the table on either side of the wall."""
    rng = np.random.default_rng(0)
    qa = planner.ik(down_pose(0.5, 0.2, 0.15), HOME_Q, rng, collision_free=True)
    qb = planner.ik(down_pose(0.5, -0.2, 0.15), HOME_Q, rng, collision_free=True)
    return qa, qb


def test_free_motion_goes_over_the_wall(planner: MotionPlanner, wall_model: mujoco.MjModel,
                                        sides: tuple) -> None:
    qa, qb = sides
    data = home_data(wall_model)
    straight = penetrations(wall_model, data, np.stack([qa, qb]))
    assert any("wall" in (b1, b2) for _, b1, b2, _ in straight)  # the direct joint line hits the wall
    traj = planner.free(qa, qb, np.random.default_rng(1))
    assert traj.q[0].tobytes() == qa.tobytes() and traj.q[-1].tobytes() == qb.tobytes()
    assert penetrations(wall_model, data, traj.q) == []
    tcp = np.array([planner.fk(q).pos for q in traj.q])
    assert tcp[:, 2].max() > WALL_TOP  # it really went over
    assert traj.rate == 20.0 and traj.duration == pytest.approx((len(traj) - 1) / 20.0, abs=0.05)


def test_free_motion_to_the_start_is_a_single_sample(planner: MotionPlanner, sides: tuple) -> None:
    traj = planner.free(sides[0], sides[0], np.random.default_rng(0))
    assert len(traj) == 1 and traj.duration == 0.0 and traj.q[0].tobytes() == sides[0].tobytes()


def test_retimed_trajectory_respects_scaled_joint_limits(planner: MotionPlanner, sides: tuple) -> None:
    for seed in range(3):
        traj = planner.free(*sides, np.random.default_rng(seed))
        qd = np.diff(traj.q, axis=0) * traj.rate
        qdd = np.diff(qd[:-1], axis=0) * traj.rate  # the shorter last interval is not a 1/rate step
        assert np.all(np.abs(qd) <= planner.vmax * 1.02)
        assert np.all(np.abs(qdd) <= planner.amax * 1.10)  # finite differences of a const-accel profile
        assert np.abs(qd[0]).max() < 0.5 * planner.vmax.max()  # starts from rest
        assert np.abs(qd[-1]).max() < 0.5 * planner.vmax.max()  # arrives at rest


def test_free_motion_is_deterministic_per_seed(planner: MotionPlanner, wall_model: mujoco.MjModel,
                                               sides: tuple) -> None:
    a = planner.free(*sides, np.random.default_rng(42))
    planner.free(*sides, np.random.default_rng(7))  # an unrelated plan in between changes nothing
    b = planner.free(*sides, np.random.default_rng(42))
    fresh = MotionPlanner(wall_model, MotionConfig())
    fresh.sync(home_data(wall_model))
    c = fresh.free(*sides, np.random.default_rng(42))
    assert a.q.tobytes() == b.q.tobytes() == c.q.tobytes() and a.duration == b.duration == c.duration
    others = {planner.free(*sides, np.random.default_rng(s)).q.tobytes() for s in (1, 2, 3)}
    assert len(others) > 1  # the seed does drive the planner


def test_start_in_collision_is_plan_fail_naming_the_obstacle(planner: MotionPlanner, sides: tuple) -> None:
    inside = planner.ik(down_pose(0.5, 0.0, WALL_TOP - 0.08), HOME_Q, np.random.default_rng(0))
    with pytest.raises(MotionFailure) as info:
        planner.free(inside, sides[1], np.random.default_rng(0))
    assert info.value.stage == "plan_fail" and "start" in info.value.reason and "wall" in info.value.reason


def test_allowed_contacts_let_the_gripper_leave_an_object(wall_model: mujoco.MjModel) -> None:
    mp = MotionPlanner(wall_model, MotionConfig())
    data = home_data(wall_model)
    box_pos = data.xpos[wall_model.body("box").id]
    data.qpos[7:9] = BOX_HALF - 0.001  # fingers squeezing the 4 cm box
    mp.sync(data)
    rng = np.random.default_rng(0)
    q_grasp = mp.ik(down_pose(box_pos[0], box_pos[1], box_pos[2]), HOME_Q, rng)
    q_up = mp.ik(down_pose(box_pos[0], box_pos[1] - 0.1, 0.3), HOME_Q, rng)
    with pytest.raises(MotionFailure) as info:
        mp.free(q_grasp, q_up, rng, allowed=NO_CONTACTS)
    assert info.value.stage == "plan_fail" and "box" in info.value.reason
    traj = mp.free(q_grasp, q_up, rng, allowed=AllowedContacts(((HAND_BODY, "box"),)))
    assert traj.q[-1].tobytes() == q_up.tobytes()


def test_a_held_object_is_collision_checked(wall_model: mujoco.MjModel, sides: tuple) -> None:
    """A box held 12 cm below the TCP must clear the wall too: the arm alone could pass lower."""
    mp = MotionPlanner(wall_model, MotionConfig())
    data = home_data(wall_model)
    mp.sync(data)
    held = np.eye(4)
    held[2, 3] = 0.12  # along the TCP's approach axis (world down when pointing down)
    attached = Attachment("box", held)
    rng = np.random.default_rng(0)
    q_over = mp.ik(down_pose(0.5, 0.0, WALL_TOP + 0.06), HOME_Q, rng)
    mp.checker.configure(NO_CONTACTS, None, 0.0)
    assert mp.checker.valid(q_over)  # the bare gripper clears the wall top by ~6 cm ...
    mp.checker.configure(NO_CONTACTS, attached, 0.0)
    assert "box <-> wall" in mp.checker.explain(q_over)  # ... the held box does not
    qa = mp.ik(down_pose(0.5, 0.2, 0.3), HOME_Q, rng)
    qb = mp.ik(down_pose(0.5, -0.2, 0.3), HOME_Q, rng)
    traj = mp.free(qa, qb, np.random.default_rng(3), attached=attached)
    box, wall = wall_model.geom("box").id, wall_model.geom("wall").id
    d = mujoco.MjData(wall_model)
    adr = wall_model.jnt_qposadr[wall_model.body("box").jntadr[0]]
    fromto = np.zeros(6)
    clearance = []
    for i in range(1, len(traj)):
        for t in np.linspace(0.0, 1.0, 6):
            q = traj.q[i - 1] + t * (traj.q[i] - traj.q[i - 1])
            T = mp.fk(q).matrix() @ held
            d.qpos[adr:adr + 3] = T[:3, 3]
            mujoco.mju_mat2Quat(d.qpos[adr + 3:adr + 7], T[:3, :3].ravel())
            mujoco.mj_kinematics(wall_model, d)
            clearance.append(mujoco.mj_geomDistance(wall_model, d, box, wall, 1.0, fromto))
    assert min(clearance) > 0.0
