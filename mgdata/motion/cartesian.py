"""Straight TCP lines: interpolated poses, solved by chained IK into a continuous joint path.

Each waypoint's IK starts at the previous solution and is pulled toward it by the posture task, so the arm
moves as little as possible; a waypoint whose solution jumps by more than ``max_joint_step`` (a wrist flip, a
branch change) ends the line with ``path_discontinuity`` instead of a lurch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mgdata.motion.config import LinearConfig
from mgdata.motion.ik import IKSolver
from mgdata.motion.types import MotionFailure, Pose

ORIENTATIONS = ("hold", "slerp")


def slerp(q0: np.ndarray, q1: np.ndarray, t: float) -> np.ndarray:
    """Spherical interpolation between unit quaternions (w, x, y, z), shortest way round."""
    dot = float(np.dot(q0, q1))
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:
        q = q0 + t * (q1 - q0)
        return q / np.linalg.norm(q)
    theta = np.arccos(dot)
    return (np.sin((1 - t) * theta) * q0 + np.sin(t * theta) * q1) / np.sin(theta)


def line_poses(start: Pose, target: Pose, orientation: str, step: float, rot_step: float) -> list[Pose]:
    """Poses after ``start`` along the straight line to ``target.pos``, the last one at the target.

    ``orientation="hold"`` keeps the start orientation (the target's is ignored); ``"slerp"`` turns
    uniformly to the target's. Steps are at most ``step`` metres and ``rot_step`` radians.
    """
    if orientation not in ORIENTATIONS:
        raise ValueError(f"orientation must be one of {ORIENTATIONS}, got {orientation!r}")
    end_quat = start.quat if orientation == "hold" else target.quat
    angle = start.angle_to(Pose(target.pos, end_quat))
    dist = float(np.linalg.norm(target.pos - start.pos))
    n = max(1, int(np.ceil(max(dist / step, angle / rot_step) - 1e-9)))
    return [Pose(start.pos + (target.pos - start.pos) * (k / n), slerp(start.quat, end_quat, k / n))
            for k in range(1, n + 1)]


@dataclass(frozen=True)
class LinePath:
    """A line solved into joints: ``q`` (n+1, 7) starting at the start configuration, and the TCP's
    cumulative distance ``dist`` (m) and turned angle ``angle`` (rad) at each point."""

    q: np.ndarray
    dist: np.ndarray
    angle: np.ndarray


def chain_ik(
    ik: IKSolver,
    q_start: np.ndarray,
    start: Pose,
    poses: list[Pose],
    config: LinearConfig,
    rng: np.random.Generator,
) -> LinePath:
    """Solve ``poses`` one after the other from ``q_start``; raises ``ik_fail`` or ``path_discontinuity``.

    A waypoint that does not converge from the previous solution is retried ``ik.config.restarts`` times
    from seeds jittered by ``rng`` (half a joint step at most), each subject to the same jump limit. A step
    whose joints still jump too far is split in halves, up to ``refine_depth`` times (:func:`_reach`): near
    a singularity the joints move fast but continuously, so the halves' jumps shrink and the line keeps the
    intermediate points; a branch flip keeps its full jump in one half however fine the split.
    """
    q = np.asarray(q_start, dtype=np.float64)
    qs, dist, angle = [q], [0.0], [0.0]
    n = len(poses)
    prev = start
    for i, pose in enumerate(poses):
        where = f"line waypoint {i + 1}/{n} at {np.round(pose.pos, 3).tolist()}"
        for point, q_point in _reach(ik, q, prev, pose, config, rng, where, config.refine_depth):
            dist.append(dist[-1] + float(np.linalg.norm(point.pos - prev.pos)))
            angle.append(angle[-1] + prev.angle_to(point))
            qs.append(q_point)
            prev = point
        q = qs[-1]
    return LinePath(np.array(qs), np.array(dist), np.array(angle))


def _reach(ik: IKSolver, q: np.ndarray, prev: Pose, pose: Pose, config: LinearConfig,
           rng: np.random.Generator, where: str, depth: int) -> list[tuple[Pose, np.ndarray]]:
    """The waypoints (pose, joints) from ``prev`` (solved as ``q``) to ``pose``: ``pose`` alone, or, if its
    joints jump past ``max_joint_step``, the two halves of the step solved in turn (``depth`` more times)."""
    try:
        return [(pose, _solve_step(ik, q, pose, config, rng, where))]
    except MotionFailure as fail:
        if fail.stage != "path_discontinuity" or depth == 0:
            raise
    mid = Pose((prev.pos + pose.pos) / 2, slerp(prev.quat, pose.quat, 0.5))
    first = _reach(ik, q, prev, mid, config, rng, where, depth - 1)
    return first + _reach(ik, first[-1][1], mid, pose, config, rng, where, depth - 1)


def _solve_step(ik: IKSolver, q: np.ndarray, pose: Pose, config: LinearConfig, rng: np.random.Generator,
                where: str) -> np.ndarray:
    """IK of one waypoint from the previous solution ``q``, with jittered restarts; the solution's joints
    move at most ``max_joint_step`` from ``q``."""
    failure = None
    for k in range(ik.config.restarts + 1):
        seed = q if k == 0 else q + rng.uniform(-0.5, 0.5, size=7) * config.max_joint_step
        result = ik.attempt(pose, seed, posture=q)
        jump = float(np.max(np.abs(result.q - q)))
        if not result.converged(ik.config):
            failure = failure or MotionFailure(
                "ik_fail", f"{where}: residual {result.pos_err:.4f} m, {result.rot_err:.3f} rad "
                f"(tolerance {ik.config.pos_tol:g} m, {ik.config.rot_tol:g} rad)")
        elif jump > config.max_joint_step:
            joint = int(np.argmax(np.abs(result.q - q))) + 1
            failure = MotionFailure("path_discontinuity", f"{where}: joint{joint} jumps {jump:.3f} rad "
                                    f"(limit {config.max_joint_step:g} rad per step)")
        else:
            return result.q
    assert failure is not None
    raise failure


def line_deviation(tcp_positions: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance (m) of the points (N, 3) from the segment a–b."""
    ab = b - a
    denom = float(ab @ ab)
    t = np.zeros(len(tcp_positions)) if denom < 1e-12 else np.clip((tcp_positions - a) @ ab / denom, 0.0, 1.0)
    closest = a + t[:, None] * ab
    return float(np.max(np.linalg.norm(tcp_positions - closest, axis=1)))


def orientation_error(quats: np.ndarray, reference: np.ndarray) -> float:
    """Largest rotation angle (rad) between each (w, x, y, z) row of ``quats`` and ``reference``."""
    dots = np.clip(np.abs(quats @ reference), 0.0, 1.0)
    return float(np.max(2.0 * np.arccos(dots)))
