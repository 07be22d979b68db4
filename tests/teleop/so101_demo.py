"""An SO-101 operator's hand motion for a top-grasp demonstration, scripted from a planner demonstration.

The SO-101 leader has five joints. With its gripper pointing straight down, ``wrist_roll`` turns the grasp
about the vertical and pan/lift/elbow (``wrist_flex`` keeping the gripper vertical) place it, so every top
grasp of the Panda's planner has an exact leader pose, but only within the ~9 cm of height over which the
leader's gripper can point down at all. The operator therefore works like this: press Record and Clutch (out),
hold the leader pointing down at the top of that travel (:data:`DOWN_TOP`), press Clutch (in: this pose now
corresponds to the Panda's current TCP), move; when the hand runs out of travel, Clutch out, bring the leader
back to :data:`DOWN_TOP` (or :data:`DOWN_LOW` when the motion goes up), Clutch in, continue.
:func:`operator_script` turns a planner demonstration into exactly that: for each planner step, the leader
joints whose mapped pose is the Panda's TCP pose (least squares on the SO-101's kinematic model, warm-started
at the previous step), with clutch strokes inserted wherever the next pose has no exact leader pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from mgdata.motion.config import load_motion_config
from mgdata.motion.ik import IKSolver
from mgdata.motion.types import Pose
from mgdata.teleop.so101.kinematics import SO101Kinematics

DOWN_TOP = np.array([-0.003, -0.383, 0.364, 1.59, 0.046])
"""Leader joints (rad): gripper pointing straight down, 18 cm in front of the base, 8 cm up."""
DOWN_LOW = np.array([-0.003, -0.324, 0.687, 1.208, 0.046])
"""The same, 3 cm up."""
JAW_OPEN, JAW_CLOSED = 1.2, 0.0
"""Physical gripper-joint angles (rad) of an open and a squeezed leader jaw."""
FLOOR_M = 0.01
"""The leader's gripper frame stays this high above its desk (m)."""
MOVE_STEPS = 12
"""Control steps the operator takes to bring the leader back while the clutch is out."""
PAUSE_STEPS = 4
"""Control steps the operator holds still before a clutch stroke (the rate-limited target catches up)."""
TOLERANCE = (2e-3, np.radians(5.0))
"""A leader pose this close (m, rad) to the pose it should map to counts as exact."""


@dataclass(frozen=True)
class OperatorScript:
    """The operator's hand per control step ``n`` (row ``n - 1``; step ``n`` reads the leader at
    ``(n - 1) · 50 ms``).

    Attributes:
        arm: (N, 5) leader arm joints (rad); jaw: (N,) physical gripper-joint angle (rad).
        presses: step n → buttons pressed after step n (0: before the first step).
        worst_m, worst_rad: the largest residual between a leader pose and the pose it should map to.
        strokes: clutch strokes (out and back in) after the first engagement.
    """

    arm: np.ndarray
    jaw: np.ndarray
    presses: dict[int, tuple[str, ...]]
    worst_m: float
    worst_rad: float
    strokes: int


def operator_script(actions: np.ndarray, q_home: np.ndarray, scale: float) -> OperatorScript:
    """The leader motion that makes the mapped Panda TCP follow ``actions`` ((n, 8): joints + gripper)."""
    fk = SO101Kinematics()
    ik = IKSolver(Pose.identity(), load_motion_config().ik)

    def solve(p_t: np.ndarray, r_t: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, float, float]:
        def residual(x: np.ndarray) -> np.ndarray:
            p, r = fk.ee(x)  # position in mm against orientation in degrees: 1 mm ≈ 1°
            return np.concatenate([(p - p_t) * 1000.0, Rotation.from_matrix(r_t.T @ r).as_rotvec() * 57.3])

        q = least_squares(residual, np.clip(q0, fk.lower, fk.upper), bounds=(fk.lower, fk.upper),
                          xtol=1e-12, ftol=1e-12).x
        p, r = fk.ee(q)
        return q, float(np.linalg.norm(p - p_t)), float(np.linalg.norm(Rotation.from_matrix(r_t.T @ r)
                                                                      .as_rotvec()))

    arm: list[np.ndarray] = [DOWN_TOP, DOWN_TOP]  # step 1: clutch out; step 2: clutch in (anchor)
    jaw: list[float] = [JAW_OPEN, JAW_OPEN]
    presses: dict[int, tuple[str, ...]] = {0: ("record", "clutch"), 1: ("clutch",)}
    anchor_q, panda = DOWN_TOP, ik.fk(q_home)
    q, worst_m, worst_rad, strokes = DOWN_TOP.copy(), 0.0, 0.0, 0
    for j, a in enumerate(actions):
        tcp = ik.fk(a[:7])
        for attempt in range(2):
            p_c, r_c = fk.ee(anchor_q)
            p_t = p_c + (tcp.pos - panda.pos) / scale
            r_t = tcp.rotation() @ panda.rotation().T @ r_c
            q_new, err_m, err_rad = solve(p_t, r_t, q)
            if p_t[2] >= FLOOR_M and err_m < TOLERANCE[0] and err_rad < TOLERANCE[1]:
                break
            if attempt == 1:
                raise ValueError(f"planner step {j}: no leader pose within tolerance even after a clutch "
                                 f"stroke ({err_m * 1000:.1f} mm, {np.degrees(err_rad):.1f}°)")
            # pause, clutch out (the Panda holds at step j - 1), bring the hand back, clutch in
            anchor_q = DOWN_TOP if p_t[2] < p_c[2] else DOWN_LOW
            for _ in range(PAUSE_STEPS):
                arm.append(q)
                jaw.append(jaw[-1])
            presses[len(arm)] = ("clutch",)
            arm.append(q)
            jaw.append(jaw[-1])
            for s in np.linspace(0.0, 1.0, MOVE_STEPS):
                arm.append(q + s * (anchor_q - q))
                jaw.append(jaw[-1])
            presses[len(arm)] = ("clutch",)
            arm.append(anchor_q)
            jaw.append(jaw[-1])
            q, panda, strokes = anchor_q.copy(), ik.fk(actions[j - 1, :7]), strokes + 1
        q = q_new
        worst_m, worst_rad = max(worst_m, err_m), max(worst_rad, err_rad)
        arm.append(q)
        jaw.append(JAW_CLOSED if a[7] > 0.5 else JAW_OPEN)
    return OperatorScript(np.array(arm), np.array(jaw), presses, worst_m, worst_rad, strokes)
