"""ArmServo: the Panda's joint position servos as a static model, for commands that mean a force.

Each arm actuator is a position servo ``tau = kp (ctrl - q) - kv qdot``; nothing compensates gravity, so
an arm commanded to ``q`` rests a few millimetres below it (≈ 5 mm at the TCP over the table). At rest,
with no contact, ``kp (ctrl - q) = g(q)`` (the gravity torques), so

* :meth:`ArmServo.rest_command` ``(q) = q + g(q) / kp`` is the command under which the arm rests at ``q``
  pushing on nothing (:meth:`ArmServo.rest_pose` inverts it);
* a command that leads that one by ``δ`` metres of TCP travel along a unit direction ``d`` pushes with
  at most ``k_d δ`` newtons along ``d`` once blocked, where ``k_d`` = :meth:`ArmServo.stiffness` ``(q, d)``
  (N/m) is the servos' stiffness with the hand pinned (K = diag(kp) seen through the TCP's 6×7 Jacobian).
  A contact that lets the hand slide or turn, or a soft one in series, is softer, so the real force is
  lower (measured on a box top: ≈ 0.4 k_d).

Example::

    servo = ArmServo(scene.model)
    ctrl = servo.rest_command(scene.arm_q())
    k = servo.stiffness(scene.arm_q(), np.array([0.0, 0.0, -1.0]))   # N/m downwards
"""

from __future__ import annotations

import mujoco
import numpy as np

from mgdata.sim import robot


class ArmServo:
    """The static servo model of the arm in ``model`` (its own scratch ``MjData``; the live one is untouched).

    Attributes:
        kp: (7,) position gains of the arm servos (N·m/rad).
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self._data = mujoco.MjData(model)
        act = robot.arm_actuator_ids(model)[:7]
        self.kp = -model.actuator_biasprm[act, 1].copy()
        self._qadr = robot.arm_qpos_adr(model)
        self._dof = robot.arm_dof_adr(model)
        self._tcp = model.site(robot.TCP_SITE).id

    def _pose(self, q: np.ndarray) -> mujoco.MjData:
        d = self._data
        d.qpos[self._qadr] = q
        d.qvel[:] = 0.0
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        return d

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Joint torques (7,) that hold the arm still at ``q`` against gravity (N·m)."""
        d = self._pose(q)
        out = np.zeros(self.model.nv)
        mujoco.mj_rne(self.model, d, 0, out)
        return out[self._dof]

    def rest_command(self, q: np.ndarray) -> np.ndarray:
        """The joint command (7,) under which the arm rests at ``q`` with no contact force."""
        return np.asarray(q, dtype=np.float64) + self.gravity(q) / self.kp

    def rest_pose(self, command: np.ndarray, iterations: int = 8) -> np.ndarray:
        """Where the arm comes to rest (7,) under the joint ``command`` with no contact: the inverse of
        :meth:`rest_command`, by fixed-point iteration (``g / kp`` changes little with ``q``)."""
        c = np.asarray(command, dtype=np.float64)
        q = c.copy()
        for _ in range(iterations):
            q = c - self.gravity(q) / self.kp
        return q

    def displace(self, q: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """The arm configuration (7,) near ``q`` that moves the TCP by the small world ``offset`` (m) with
        its orientation kept (one damped least-squares step on the TCP's 6×7 Jacobian)."""
        d = self._pose(q)
        jp, jr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        mujoco.mj_jacSite(self.model, d, jp, jr, self._tcp)
        j = np.vstack([jp, jr])[:, self._dof]
        err = np.concatenate([np.asarray(offset, dtype=np.float64), np.zeros(3)])
        return np.asarray(q, dtype=np.float64) + j.T @ np.linalg.solve(j @ j.T + 1e-8 * np.eye(6), err)

    def stiffness(self, q: np.ndarray, direction: np.ndarray) -> float:
        """The servos' stiffness (N/m) at the TCP along the unit vector ``direction`` at ``q`` with the hand
        pinned (position and orientation held, as by a firm contact): ``dᵀ [(J K⁻¹ Jᵀ)⁻¹]_pos d`` with J the
        TCP's 6×7 Jacobian. Any looser contact (sliding, turning, a soft surface) is softer, so a command
        leading the rest command by ``δ`` pushes with at most ``stiffness · δ``."""
        d = self._pose(q)
        jp, jr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        mujoco.mj_jacSite(self.model, d, jp, jr, self._tcp)
        j = np.vstack([jp, jr])[:, self._dof]
        pinned = np.linalg.inv((j / self.kp) @ j.T)[:3, :3]
        u = np.asarray(direction, dtype=np.float64)
        return float(u @ pinned @ u)
