"""Inverse kinematics of the Panda TCP with mink, on a kinematics-only copy of the arm.

The solver works on a 7-joint model of the bare arm (no geoms, no fingers, no scene objects), so each QP has
seven unknowns whatever the scene holds; targets given in the world are moved into the robot base frame
first. mink is a local solver: an attempt starts at ``q_seed``, later attempts start from seeds perturbed
by growing Gaussian noise drawn from the caller's ``rng`` (so results are reproducible per seed), and the last
one from ``HOME_Q`` (an arm left twisted by an earlier motion can strand every perturbed seed).

Example::

    solver = IKSolver(base=Pose.identity(), config=IKConfig())
    q = solver.solve(solver.fk(HOME_Q), HOME_Q, np.random.default_rng(0))
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from mgdata.motion.config import IKConfig
from mgdata.motion.types import MotionFailure, Pose
from mgdata.sim.robot import ARM_JOINTS, FINGER_JOINTS, HOME_Q, TCP_SITE, load_panda_spec


@functools.cache
def kinematic_arm_model() -> mujoco.MjModel:
    """The Panda arm reduced to bodies, joints ``joint1..7`` and sites (base at the origin); cached."""
    spec = load_panda_spec(decimate_visuals=False)
    for kind in ("keys", "sensors", "actuators", "equalities", "tendons", "geoms", "meshes", "materials",
                 "textures"):
        for element in list(getattr(spec, kind)):
            spec.delete(element)
    for name in FINGER_JOINTS:
        spec.delete(spec.joint(name))
    model = spec.compile()
    assert tuple(model.joint(i).name for i in range(model.njnt)) == ARM_JOINTS
    return model


@dataclass(frozen=True)
class IKResult:
    """One IK attempt: the configuration reached and its residuals."""

    q: np.ndarray
    pos_err: float
    rot_err: float

    def converged(self, config: IKConfig) -> bool:
        return self.pos_err <= config.pos_tol and self.rot_err <= config.rot_tol

    @property
    def score(self) -> float:
        """Residual for ranking unconverged attempts: metres plus 0.1 m per radian."""
        return self.pos_err + 0.1 * self.rot_err


class IKSolver:
    """mink IK for the TCP site of a Panda whose base sits at ``base`` in the world.

    Attributes:
        base: world pose of the robot's root body.
        lower, upper: (7,) joint limits (rad).
    """

    def __init__(self, base: Pose, config: IKConfig) -> None:
        self.base = base
        self.config = config
        self._world_T_base = base.matrix()
        self._base_T_world = np.linalg.inv(self._world_T_base)
        model = kinematic_arm_model()
        self._model = model
        self._cfg = mink.Configuration(model)
        self._site = model.site(TCP_SITE).id
        self.lower = model.jnt_range[:, 0].copy()
        self.upper = model.jnt_range[:, 1].copy()
        self._task = mink.FrameTask(TCP_SITE, "site", position_cost=1.0, orientation_cost=1.0)
        self._posture = mink.PostureTask(model, cost=config.posture_cost)
        self._limits = [mink.ConfigurationLimit(model, min_distance_from_limits=config.limit_margin)]

    def fk(self, q: np.ndarray) -> Pose:
        """World pose of the TCP at arm configuration ``q`` (7,)."""
        self._cfg.update(np.asarray(q, dtype=np.float64))
        return self._tcp_world()

    def _tcp_world(self) -> Pose:
        data = self._cfg.data
        T = np.eye(4)
        T[:3, :3] = data.site_xmat[self._site].reshape(3, 3)
        T[:3, 3] = data.site_xpos[self._site]
        return Pose.from_matrix(self._world_T_base @ T)

    def clip(self, q: np.ndarray) -> np.ndarray:
        """``q`` moved inside the joint limits by the configured margin."""
        m = self.config.limit_margin
        return np.clip(q, self.lower + m, self.upper - m)

    def attempt(self, target: Pose, q_seed: np.ndarray, posture: np.ndarray | None = None) -> IKResult:
        """One local solve from ``q_seed`` (no restarts); ``posture`` defaults to ``HOME_Q``."""
        cfg, c = self._cfg, self.config
        local = self._base_T_world @ target.matrix()
        target_pos, target_rot = local[:3, 3], local[:3, :3]
        self._task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(target_rot),
                                                                     target_pos))
        self._posture.set_target(HOME_Q if posture is None else np.asarray(posture, dtype=np.float64))
        cfg.update(self.clip(np.asarray(q_seed, dtype=np.float64)))
        tasks = [self._task, self._posture]
        pos_err, rot_err = self._residual(target_pos, target_rot)
        best = IKResult(cfg.q.copy(), pos_err, rot_err)
        if best.converged(c):
            return best
        for _ in range(c.max_iters):
            if pos_err < c.polish_radius:
                # Near the target the posture pull would bias the fixed point; keep it as damping only.
                self._posture.set_target(cfg.q)
            try:
                v = mink.solve_ik(cfg, tasks, 1.0, c.solver, damping=c.damping, limits=self._limits)
            except mink.NoSolutionFound:
                break
            cfg.integrate_inplace(v, 1.0)
            pos_err, rot_err = self._residual(target_pos, target_rot)
            current = IKResult(cfg.q.copy(), pos_err, rot_err)
            if current.converged(c):
                return current
            if current.score < best.score:
                best = current
        return best

    def _residual(self, target_pos: np.ndarray, target_rot: np.ndarray) -> tuple[float, float]:
        data = self._cfg.data
        pos_err = float(np.linalg.norm(data.site_xpos[self._site] - target_pos))
        rel = target_rot.T @ data.site_xmat[self._site].reshape(3, 3)
        rot_err = float(np.arccos(np.clip((np.trace(rel) - 1.0) / 2.0, -1.0, 1.0)))
        return pos_err, rot_err

    def solve(
        self,
        target: Pose,
        q_seed: np.ndarray,
        rng: np.random.Generator,
        posture: np.ndarray | None = None,
        accept: Callable[[np.ndarray], str | None] | None = None,
    ) -> np.ndarray:
        """A converged solution near ``q_seed``, trying seeded restarts; raises MotionFailure("ik_fail").

        ``accept(q)`` may veto a converged solution by returning a reason (e.g. a collision); the next
        restart is then tried.
        """
        c = self.config
        q_seed = np.asarray(q_seed, dtype=np.float64)
        best: IKResult | None = None
        vetoes: list[str] = []
        for k in range(c.restarts + 2):
            seed = q_seed
            if k > c.restarts:  # last, from home: a seed far from the start can strand the solver
                seed = HOME_Q
            elif k > 0:
                seed = q_seed + rng.normal(0.0, c.restart_sigma * k / c.restarts, size=7)
            result = self.attempt(target, seed, posture)
            if result.converged(c):
                veto = accept(result.q) if accept is not None else None
                if veto is None:
                    return result.q
                vetoes.append(veto)
            elif best is None or result.score < best.score:
                best = result
        attempts = c.restarts + 2
        if vetoes:
            reason = f"{len(vetoes)} of {attempts} attempts converged but were rejected: {vetoes[0]}"
        else:
            assert best is not None
            reason = (f"no solution within {c.pos_tol:g} m / {c.rot_tol:g} rad after {attempts} attempts; "
                      f"best residual {best.pos_err:.4f} m, {best.rot_err:.3f} rad "
                      f"(target {np.round(target.pos, 3).tolist()})")
        raise MotionFailure("ik_fail", reason)
