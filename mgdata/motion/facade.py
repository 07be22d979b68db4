"""MotionPlanner: the one way mgdata turns targets into executable joint trajectories.

Every method returns a :class:`~mgdata.motion.types.JointTrajectory` sampled at the control rate, or raises
:class:`~mgdata.motion.types.MotionFailure` with a stage and a reason. Given the same scene state, inputs and
``rng`` state, every result is bit-identical (no wall-clock budgets anywhere).

Example::

    mp = MotionPlanner(model, load_motion_config())
    mp.sync(data)                                        # object poses, finger opening
    q_pre = mp.ik(pregrasp, data.qpos[:7], rng, collision_free=True)
    traj = mp.free(data.qpos[:7], q_pre, rng)            # around obstacles, retimed, rechecked
    down = mp.linear(traj.end, grasp, rng, allowed=AllowedContacts((("hand", "jar"),)))
    up = mp.reverse(down)
"""

from __future__ import annotations

import mujoco
import numpy as np

from mgdata.errors import RobotModelError
from mgdata.motion.cartesian import LinePath, chain_ik, line_deviation, line_poses
from mgdata.motion.collision import CollisionChecker
from mgdata.motion.config import MotionConfig
from mgdata.motion.ik import IKSolver
from mgdata.motion.planner import plan_joint_path
from mgdata.motion.retime import densify, retime
from mgdata.motion.types import NO_CONTACTS, AllowedContacts, Attachment, JointTrajectory, MotionFailure, Pose
from mgdata.sim.robot import AMAX, HOME_Q, ROOT_BODY, VMAX


class MotionPlanner:
    """IK, free-space planning, straight lines and reverse replay for the Panda in one scene.

    Args:
        model: any compiled scene holding the Panda with its standard element names.
        config: tunables (``load_motion_config()`` reads ``recipes/motion.toml``).

    Attributes:
        checker: the private collision checker (its own copy of the model and data).
        lower, upper: (7,) arm joint limits (rad).
        vmax, amax: (7,) joint velocity / acceleration limits used for retiming (datasheet × scale).
    """

    def __init__(self, model: mujoco.MjModel, config: MotionConfig | None = None) -> None:
        self.config = config or MotionConfig()
        self.checker = CollisionChecker(model, self.config.check)
        data = self.checker.data
        mujoco.mj_kinematics(self.checker.model, data)
        root = model.body(ROOT_BODY).id
        base = Pose(data.xpos[root], data.xquat[root])
        self._ik = IKSolver(base, self.config.ik)
        self.lower, self.upper = self._ik.lower, self._ik.upper
        fk_err = np.abs(self._ik.fk(HOME_Q).matrix() - self.checker.world_T_tcp(HOME_Q)).max()
        if fk_err > 1e-6:
            raise RobotModelError(f"the scene's Panda differs from the standard arm kinematics (TCP at HOME "
                                  f"off by {fk_err:.2e}); motion planning needs the unmodified arm")
        r = self.config.retime
        self.vmax = VMAX * r.speed_scale
        self.amax = AMAX * r.accel_scale

    # ------------------------------------------------------------------------------------------ state
    def sync(self, data: mujoco.MjData) -> None:
        """Copy the live world state (objects, articulations, fingers) into the checker."""
        self.checker.sync(data)

    def fk(self, q: np.ndarray) -> Pose:
        """World pose of the TCP at arm configuration ``q`` (7,)."""
        return self._ik.fk(_q7(q, "q"))

    # ------------------------------------------------------------------------------------------ IK
    def ik(
        self,
        target: Pose,
        q_seed: np.ndarray,
        rng: np.random.Generator,
        *,
        collision_free: bool = False,
        allowed: AllowedContacts = NO_CONTACTS,
        attached: Attachment | None = None,
        limit_margin: float = 0.0,
    ) -> np.ndarray:
        """Arm configuration (7,) putting the TCP at ``target``, near ``q_seed``; raises ``ik_fail``.

        With ``collision_free`` a solution must also be free of (exact, unallowed) contacts in the synced
        scene, and with ``limit_margin`` (rad) keep that far from every joint limit, or the next restart is
        tried.
        """
        q_seed = _q7(q_seed, "q_seed")
        if collision_free:
            self.checker.configure(allowed, attached, 0.0)

        def accept(q: np.ndarray) -> str | None:
            room = float(np.min(np.minimum(q - self.lower, self.upper - q)))
            if room < limit_margin:
                return f"{room:.3f} rad from a joint limit (needs {limit_margin:g})"
            if collision_free and not self.checker.valid(q):
                return f"in collision ({self.checker.explain(q)})"
            return None

        return self._ik.solve(target, q_seed, rng,
                              accept=accept if collision_free or limit_margin > 0.0 else None)

    # ------------------------------------------------------------------------------------------ free
    def free(
        self,
        q_start: np.ndarray,
        q_goal: np.ndarray,
        rng: np.random.Generator,
        allowed: AllowedContacts = NO_CONTACTS,
        attached: Attachment | None = None,
    ) -> JointTrajectory:
        """Collision-free joint motion (RRTConnect, simplified, toppra-retimed, densely rechecked).

        Raises ``MotionFailure`` with stage ``plan_fail`` (start/goal in collision, or no path),
        ``retime_fail`` or ``collision_recheck``.
        """
        q_start, q_goal = _q7(q_start, "q_start"), _q7(q_goal, "q_goal")
        seed = int(rng.integers(0, 2**31 - 1))
        c, chk = self.config, self.checker
        chk.configure(allowed, attached, 0.0)
        for name, q in (("start", q_start), ("goal", q_goal)):
            if not chk.valid(q):
                raise MotionFailure("plan_fail", f"{name} configuration is in collision: {chk.explain(q)}")
        chk.set_margin(c.check.margin)
        chk.relax_pairs_at(q_start)
        chk.relax_pairs_at(q_goal)
        if np.max(np.abs(q_goal - q_start)) < 1e-9:
            return JointTrajectory(q_start[None], c.retime.rate, 0.0)
        lower, upper = np.minimum(self.lower, np.minimum(q_start, q_goal)), np.maximum(
            self.upper, np.maximum(q_start, q_goal))
        direct = np.stack([q_start, q_goal])
        if chk.first_invalid(direct, self._motion_step()) is None:
            waypoints = direct
        else:
            waypoints = plan_joint_path(chk, q_start, q_goal, lower, upper, seed, c.planner, c.check)
        traj = retime(densify(waypoints, c.planner.waypoint_step), self.vmax, self.amax, c.retime.rate,
                      c.retime.gridpoints_per_waypoint)
        self._recheck(traj)
        return traj

    def _motion_step(self) -> float:
        """OMPL's motion-check step in radians (the resolution is a fraction of the space's extent)."""
        return self.config.check.resolution * float(np.linalg.norm(self.upper - self.lower))

    def _recheck(self, traj: JointTrajectory) -> None:
        """Exact (uninflated) check between consecutive samples; raises ``collision_recheck``."""
        chk = self.checker
        chk.set_margin(0.0)
        bad = chk.first_invalid(traj.q, self.config.check.recheck_step)
        if bad is not None:
            index, q = bad
            raise MotionFailure("collision_recheck", f"retimed trajectory collides after sample {index} "
                                f"(t = {index / traj.rate:.2f} s of {traj.duration:.2f} s): {chk.explain(q)}")

    # ------------------------------------------------------------------------------------------ lines
    def linear(
        self,
        q_start: np.ndarray,
        target: Pose,
        rng: np.random.Generator,
        orientation: str = "hold",
        allowed: AllowedContacts = NO_CONTACTS,
        attached: Attachment | None = None,
    ) -> JointTrajectory:
        """Straight TCP line from ``fk(q_start)`` to ``target.pos`` by chained IK, retimed under the joint
        limits and the configured TCP speed caps.

        ``orientation="hold"`` keeps the start orientation; ``"slerp"`` turns uniformly to ``target.quat``.
        Raises ``MotionFailure`` with stage ``ik_fail``, ``path_discontinuity``, ``plan_fail`` (the line
        collides), ``retime_fail`` or ``collision_recheck``.
        """
        q_start = _q7(q_start, "q_start")
        c, lc = self.config, self.config.linear
        start = self.fk(q_start)
        line = self.line(q_start, target, rng, orientation, allowed, attached)
        waypoints = np.column_stack([line.q, line.dist, line.angle])
        vmax = np.concatenate([self.vmax, [lc.speed, lc.angular_speed]])
        amax = np.concatenate([self.amax, [lc.accel, lc.angular_accel]])
        traj = retime(waypoints, vmax, amax, c.retime.rate, c.retime.gridpoints_per_waypoint)
        tcp = np.array([self._ik.fk(q).pos for q in traj.q])
        deviation = line_deviation(tcp, start.pos, target.pos)
        if deviation > lc.max_line_error:
            raise MotionFailure("retime_fail", f"retimed line leaves the straight line by "
                                f"{deviation * 1000:.1f} mm (limit {lc.max_line_error * 1000:.1f} mm)")
        self._recheck(traj)
        return traj

    def line(
        self,
        q_start: np.ndarray,
        target: Pose,
        rng: np.random.Generator,
        orientation: str = "hold",
        allowed: AllowedContacts = NO_CONTACTS,
        attached: Attachment | None = None,
    ) -> LinePath:
        """The straight TCP line of :meth:`linear` solved into joints and checked, not yet retimed: waypoints
        every ``[linear] step`` metres with the TCP's distance along the line. Raises ``ik_fail``,
        ``path_discontinuity`` or ``plan_fail`` (the line collides)."""
        q_start = _q7(q_start, "q_start")
        c, lc, chk = self.config, self.config.linear, self.checker
        start = self.fk(q_start)
        poses = line_poses(start, target, orientation, lc.step, lc.rot_step)
        line = chain_ik(self._ik, q_start, start, poses, lc, rng)
        chk.configure(allowed, attached, 0.0)
        if not chk.valid(q_start):
            raise MotionFailure("plan_fail", f"start configuration is in collision: {chk.explain(q_start)}")
        chk.set_margin(lc.check_margin)
        chk.relax_pairs_at(q_start)
        bad = chk.first_invalid(line.q, c.check.recheck_step)
        if bad is not None:
            index, q = bad
            raise MotionFailure("plan_fail", f"line collides near waypoint {index + 1}/{len(poses)} "
                                f"({line.dist[index]:.3f} m along): {chk.explain(q)}")
        return line

    def reverse(self, traj: JointTrajectory) -> JointTrajectory:
        """Replay ``traj`` backwards: same samples and timing, from its end to its start."""
        return traj.reversed()


def _q7(q: np.ndarray, name: str) -> np.ndarray:
    arr = np.asarray(q, dtype=np.float64)
    if arr.shape != (7,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be 7 finite arm joint angles, got shape {arr.shape}")
    return arr.copy()
