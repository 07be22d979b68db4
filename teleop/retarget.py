"""SO-101 → Panda retargeting: the leader's end effector mapped absolutely onto the Panda TCP, then IK.

Per control step (all poses in the Panda base frame):

1. **map**: ``p = p_ref + scale · A (p_L − p_L,ref)`` and ``R = A R_L R_L,refᵀ Aᵀ R_ref`` with ``A`` the frame
   alignment and ``scale`` from the calibration file; the reference pair starts as (leader at the middle of
   every joint, Panda TCP at ``HOME_Q``). The **clutch** toggles: pressed once, it disengages (the target
   holds still whatever the leader does, so the operator can reposition their hand, e.g. lift a leader whose
   gripper points down back to the top of its short vertical travel); pressed again, it re-engages and
   re-anchors the pair (leader now ↔ target now);
2. **clamp** the position into the workspace box;
3. **rate-limit** the target: at most ``max_step_m`` and ``max_step_rad`` from the previous target;
4. **IK** with mink, one local solve warm-started at the current joints (posture pulled to them too);
5. **joint-step limit**: the step is scaled down so no joint moves more than ``max_joint_step``.

Example::

    rt = Retargeter(cal, config.retarget, q0=HOME_Q)
    step = rt.step(leader_q, clutch=False)
    step.q            # (7,) Panda joint command
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from mgdata.motion.config import load_motion_config
from mgdata.motion.ik import IKSolver
from mgdata.motion.types import Pose
from mgdata.sim.robot import HOME_Q
from mgdata.teleop.config import RetargetConfig
from mgdata.teleop.so101.calibration import SO101Calibration
from mgdata.teleop.so101.kinematics import SO101Kinematics


@dataclass(frozen=True)
class RetargetStep:
    """One control step of retargeting.

    Attributes:
        q: the Panda joint command (rad, (7,)).
        mapped: the leader's pose mapped into the Panda frame (before the clamp).
        target: the TCP target after the clamp and the rate limit (what IK solved for).
        clamped: the workspace clamp moved the mapped position.
        ik_ok: IK converged to the target within its tolerances.
        engaged: the target followed the leader (``False`` while the clutch is out).
    """

    q: np.ndarray
    mapped: Pose
    target: Pose
    clamped: bool
    ik_ok: bool
    engaged: bool = True


class Retargeter:
    """Stateful SO-101 → Panda mapping (see the module docstring).

    Attributes:
        ik_failures: control steps on which IK did not converge.
        engaged: the target follows the leader (the clutch toggles it).
    """

    def __init__(self, cal: SO101Calibration, config: RetargetConfig, q0: np.ndarray = HOME_Q) -> None:
        self.config = config
        self.scale = cal.scale
        self.align = Pose(np.zeros(3), np.asarray(cal.align_quat)).rotation()
        self.fk = SO101Kinematics()
        self.ik = IKSolver(Pose.identity(), load_motion_config().ik)
        self.q = np.asarray(q0, dtype=np.float64).copy()
        self.target = self.ik.fk(self.q)
        self._leader_ref = self.fk.ee(np.zeros(5))
        home = self.ik.fk(HOME_Q)
        self._panda_ref = (home.pos, home.rotation())
        self._lo, self._hi = np.asarray(config.workspace_lo), np.asarray(config.workspace_hi)
        self.ik_failures = 0
        self.engaged = True

    def reanchor(self, leader_q: np.ndarray) -> None:
        """Clutch: the leader's pose now corresponds to the current target from here on."""
        self._leader_ref = self.fk.ee(leader_q)
        self._panda_ref = (self.target.pos.copy(), self.target.rotation())

    def mapped(self, leader_q: np.ndarray) -> Pose:
        """The leader pose mapped into the Panda base frame (no clamp, no limits)."""
        p_l, r_l = self.fk.ee(leader_q)
        (p0_l, r0_l), (p0, r0) = self._leader_ref, self._panda_ref
        a = self.align
        pos = p0 + self.scale * a @ (p_l - p0_l)
        rot = a @ r_l @ r0_l.T @ a.T @ r0
        return Pose.from_pos_mat(pos, rot)

    def step(self, leader_q: np.ndarray, clutch: bool = False) -> RetargetStep:
        """One control step: map, clamp, rate-limit, IK, joint-step limit. ``clutch``: the operator pressed
        the clutch before this step (disengage, or re-engage and re-anchor)."""
        c = self.config
        if clutch:
            self.engaged = not self.engaged
            if self.engaged:
                self.reanchor(leader_q)
        mapped = self.mapped(leader_q)
        if not self.engaged:  # the target holds; IK keeps the arm on it
            return self._solve(mapped, self.target, False)
        pos = np.clip(mapped.pos, self._lo, self._hi)
        clamped = bool(np.any(np.abs(pos - mapped.pos) > 1e-12))
        dp = pos - self.target.pos
        dist = float(np.linalg.norm(dp))
        if dist > c.max_step_m:
            pos = self.target.pos + dp * (c.max_step_m / dist)
        r_prev = Rotation.from_quat(self.target.quat, scalar_first=True)
        rel = (r_prev.inv() * Rotation.from_quat(mapped.quat, scalar_first=True)).as_rotvec()
        angle = float(np.linalg.norm(rel))
        if angle > c.max_step_rad:
            rel = rel * (c.max_step_rad / angle)
        quat = (r_prev * Rotation.from_rotvec(rel)).as_quat(scalar_first=True)
        return self._solve(mapped, Pose(pos, quat), clamped)

    def _solve(self, mapped: Pose, target: Pose, clamped: bool) -> RetargetStep:
        """IK to ``target`` from the current joints, the joint step limited."""
        c = self.config
        self.target = target
        result = self.ik.attempt(self.target, self.q, posture=self.q)
        ok = result.converged(self.ik.config)
        if not ok:
            self.ik_failures += 1
        dq = result.q - self.q
        worst = float(np.max(np.abs(dq)))
        if worst > c.max_joint_step:
            dq = dq * (c.max_joint_step / worst)
        self.q = self.q + dq
        return RetargetStep(self.q.copy(), mapped, self.target, clamped, ok, self.engaged)
