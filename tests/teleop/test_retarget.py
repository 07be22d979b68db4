"""SO-101 → Panda retargeting on scripted leader trajectories; the TCP is measured by the test with MuJoCo
forward kinematics of the Panda model, independently of the retargeter's IK."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.motion.ik import kinematic_arm_model
from mgdata.sim.robot import HOME_Q, TCP_SITE
from mgdata.teleop.config import RetargetConfig, load_teleop_config
from mgdata.teleop.retarget import Retargeter
from mgdata.teleop.so101.calibration import MOTOR_NAMES, MotorCalibration, SO101Calibration

CAL = SO101Calibration("emulated", 1_000_000,
                       {n: MotorCalibration(k + 1, 0, 0, 1000, 3094) for k, n in enumerate(MOTOR_NAMES)})
CONFIG = load_teleop_config().retarget


def _tcp(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    model = kinematic_arm_model()
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_kinematics(model, data)
    site = model.site(TCP_SITE).id
    return data.site_xpos[site].copy(), data.site_xmat[site].reshape(3, 3).copy()


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1))))


def _leader(t: float, amp: float = 1.0) -> np.ndarray:
    """A smooth hand motion of the five SO-101 joints (rad)."""
    return amp * np.array([0.5 * np.sin(0.3 * t), 0.25 * np.sin(0.2 * t + 0.5), -0.3 * np.sin(0.25 * t),
                           0.4 * np.sin(0.35 * t), 0.6 * np.sin(0.15 * t)])


def _mat(quat: np.ndarray) -> np.ndarray:
    m = np.empty(9)
    mujoco.mju_quat2Mat(m, quat)
    return m.reshape(3, 3)


def test_tracks_the_mapped_target_in_the_workspace_without_ik_failures() -> None:
    """1,000 in-workspace control steps: TCP within 5 mm / 3° of the mapped target, no joint step > 0.05 rad,
    no IK failure."""
    rt = Retargeter(CAL, CONFIG, q0=HOME_Q)
    lo, hi = np.array(CONFIG.workspace_lo), np.array(CONFIG.workspace_hi)
    q_prev = HOME_Q.copy()
    checked = 0
    for k in range(1000):
        step = rt.step(_leader(k / 20.0, amp=0.6))
        assert not step.clamped, "the scripted motion is meant to stay inside the workspace"
        assert np.max(np.abs(step.q - q_prev)) <= CONFIG.max_joint_step + 1e-12
        q_prev = step.q
        if k >= 20:  # the first steps ramp from home towards the leader under the step limits
            pos, rot = _tcp(step.q)
            assert np.linalg.norm(pos - step.mapped.pos) <= 0.005
            assert _angle(rot, _mat(step.mapped.quat)) <= 3.0
            assert np.all(pos >= lo - 0.005) and np.all(pos <= hi + 0.005)
            checked += 1
    assert rt.ik_failures == 0 and checked == 980


def test_clamps_outside_the_workspace() -> None:
    """A leader swung far to the side is clamped to the box; the TCP stops at its face."""
    rt = Retargeter(CAL, CONFIG, q0=HOME_Q)
    reach = np.array([1.5, 0.0, 0.0, 0.0, 0.0])  # shoulder_pan swung 86°: the mapped TCP leaves the box in y
    for k in range(120):
        step = rt.step(reach * min(1.0, k / 60))
    assert step.clamped
    pos, _ = _tcp(step.q)
    lo, hi = np.array(CONFIG.workspace_lo), np.array(CONFIG.workspace_hi)
    assert np.all(pos >= lo - 0.005) and np.all(pos <= hi + 0.005)
    outside = (step.mapped.pos < lo) | (step.mapped.pos > hi)
    assert outside.any()
    assert np.allclose(pos[outside], np.clip(step.mapped.pos, lo, hi)[outside], atol=0.005)


def test_step_limits_bound_a_jump() -> None:
    """A sudden leader jump moves the target by at most max_step_m per step and each joint by
    max_joint_step."""
    config = RetargetConfig()
    rt = Retargeter(CAL, config, q0=HOME_Q)
    target_before = rt.target.pos.copy()
    q_before = rt.q.copy()
    step = rt.step(np.array([0.8, 0.4, -0.5, 0.5, 1.0]))
    assert np.linalg.norm(step.target.pos - target_before) <= config.max_step_m + 1e-9
    assert np.max(np.abs(step.q - q_before)) <= config.max_joint_step + 1e-12


def test_clutch_out_holds_the_robot_and_clutch_in_reanchors() -> None:
    rt = Retargeter(CAL, CONFIG, q0=HOME_Q)
    for k in range(40):
        rt.step(_leader(k / 20.0, amp=0.4))
    held, q_held = rt.target, rt.q.copy()
    hand = _leader(2.0, amp=0.4)
    step = rt.step(hand, clutch=True)  # out: the hand moves far, the robot stays
    for k in range(10):
        step = rt.step(hand + np.array([0.03 * k, -0.02 * k, 0.04 * k, 0.0, 0.05 * k]))
        assert not step.engaged
        assert np.linalg.norm(step.target.pos - held.pos) < 1e-9 and step.target.angle_to(held) < 1e-6
    assert np.max(np.abs(rt.q - q_held)) < 1e-3
    moved_hand = hand + np.array([0.3, -0.2, 0.4, 0.0, 0.5])
    step = rt.step(moved_hand, clutch=True)  # in: this hand pose now maps onto the held target
    assert step.engaged and np.linalg.norm(step.target.pos - held.pos) < 1e-9
    assert step.target.angle_to(held) < 1e-6
    # from here the target follows the hand's motion relative to the new anchor
    nudge = moved_hand + np.array([0.05, 0.0, 0.0, 0.0, 0.0])
    d_leader = rt.fk.ee(nudge)[0] - rt.fk.ee(moved_hand)[0]
    assert np.allclose(rt.mapped(nudge).pos - held.pos, CAL.scale * d_leader, atol=1e-9)


@pytest.mark.parametrize("scale", [1.0, 2.0])
def test_scale_and_alignment_come_from_the_calibration(scale: float) -> None:
    """Moving the leader's end effector by d moves the mapped target by scale · A d."""
    yaw = np.pi / 2
    quat = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
    cal = SO101Calibration("emulated", 1, CAL.motors, quat, scale)
    rt = Retargeter(cal, CONFIG, q0=HOME_Q)
    a, b = np.zeros(5), np.array([0.3, 0.0, 0.0, 0.0, 0.0])
    d_leader = rt.fk.ee(b)[0] - rt.fk.ee(a)[0]
    d_panda = rt.mapped(b).pos - rt.mapped(a).pos
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(d_panda, scale * rot @ d_leader, atol=1e-9)
