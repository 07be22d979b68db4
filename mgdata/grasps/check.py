"""In-simulation validation of a grasp: reach it, close on the object, then lift it (a free object) or pull
its drawer open (a grasp in a drawer's frame), and see that the object comes along.

The object stands alone on the table, its articulation closed, placed so that the grasp's TCP target lies
``place_x`` in front of the robot base on its centre line, and turned so that a horizontal approach points
away from the robot (side grasps are checked from their natural direction) or, for a vertical approach,
the hand keeps its home heading (gripper +X forward); where the grasp is reachable in a real task is the
skeleton's business. The check plans with the same motion facade as the generator: a free move to the
pre-grasp pose, a straight approach, closing the gripper, then

* **lift** (free objects): a straight lift by ``lift`` and a short hold. Valid when the object rose by at
  least ``min_lift_fraction`` of the lift, both fingers still touch it and it tilted less than
  ``max_tilt_deg`` (a plate or a tray lifted by its rim must stay level);
* **pull** (a grasp whose ``frame`` is the moving link of a slide articulation: a drawer handle): a straight
  pull by ``pull`` along the slide axis and a short hold. Valid when the slide joint (read from ``qpos``)
  opened by at least ``min_pull_fraction`` of the pull and both fingers still touch the handle.

An edge pinch (:func:`needs_overhang`: a board's or a plate's edge, the lower finger under it) needs its edge
over a table edge first: the object lies by the table's back edge, behind the robot base (the one edge the
hand reaches from beyond it), and a guarded push of the open hand slides it ``slide`` over it before the
pre-grasp; the approach aims where the arm comes to rest at the pinch (:mod:`mgdata.grasps.rest`), as the
edge pick does.

Example::

    status, detail = check_grasp("jar/hinged_03", grasp, GraspCheckConfig())
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

from mgdata.errors import GraspDBError
from mgdata.grasps.db import Grasp
from mgdata.grasps.edge import needs_overhang, push_start, shortfall
from mgdata.grasps.rest import first_ik, resting_target
from mgdata.motion import AllowedContacts, Attachment, MotionFailure, MotionPlanner, Pose, load_motion_config
from mgdata.sim import robot
from mgdata.sim.assets import get_model
from mgdata.sim.config import default_image_size
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement, TaskSpec
from mgdata.sim.world import TABLE_TOP_Z, TABLE_X
from mgdata.spec import SafetySpec


@dataclass(frozen=True)
class GraspCheckConfig:
    """Tunables of the check (``recipes/grasps.toml`` ``[check]``)."""

    place_x: float = 0.50  # m in front of the robot base
    standoff: float = 0.09  # m back along the approach for the pre-grasp pose
    lift: float = 0.10  # m
    close_steps: int = 12
    hold_steps: int = 10
    min_lift_fraction: float = 0.8
    max_tilt_deg: float = 20.0
    pull: float = 0.08  # m a drawer is pulled open
    min_pull_fraction: float = 0.8
    edge_y: float = 0.35  # m left of the robot: where an edge pinch's object lies by the table's back edge
    slide: float = 0.08  # m the object is pushed towards that edge before the pinch
    edge_clearance: float = 0.010  # m between the pushed-out fingertips' reach and the table's edge
    push_tip_height: float = 0.008  # m above the table: the pushing fingertips
    push_clearance: float = 0.02  # m between the open fingers and the object where the push starts
    push_tolerance: float = 0.002  # m: the push goes on until the object lacks less than this
    push_tries: int = 4  # pushes at most (each by what the object still lacks: the arm lags while it pushes)
    seed: int = 0


def check_placement(grasp: Grasp, cfg: GraspCheckConfig,
                    model: str) -> tuple[tuple[float, float, float], float]:
    """Where the check stands object model ``model`` (``category/model``) for ``grasp``: position (m) and
    yaw (rad). The yaw turns a horizontal approach away from the robot, or a vertical one's gripper +X
    forward; the position puts the grasp's TCP target at ``place_x`` on the robot's centre line, as far as
    that moves the object by no more than its own size (a pose far from the object stays far from it). An
    edge pinch (``needs_overhang``) lies at ``edge_y`` by the table's back edge (behind the robot base, the
    one edge in reach), its TCP target ``slide`` short of where the fingertips clear that edge by
    ``edge_clearance``, so that the push of ``slide`` makes the edge overhang."""
    obj = get_model(model)
    local = grasp.matrix()
    if grasp.frame:  # a link's frame: its pose in the object's root frame, articulation closed
        link = next((lk for lk in obj.links if lk.name == grasp.frame), None)
        if link is None:
            raise GraspDBError(f"grasp {grasp.id!r}: frame {grasp.frame!r} is not a link of {model!r}")
        to_root = Pose(np.asarray(link.pos, dtype=float), np.asarray(link.quat, dtype=float)).matrix()
        local = to_root @ local
    approach, heading = local[:3, 2], local[:3, 0]
    ref = approach if np.hypot(approach[0], approach[1]) > 0.5 else heading
    yaw = -math.atan2(ref[1], ref[0]) if np.hypot(ref[0], ref[1]) > 1e-6 else 0.0
    offset = local[:2, 3].copy()
    reach = max(obj.size[0], obj.size[1])
    if np.linalg.norm(offset) > reach:
        offset *= reach / np.linalg.norm(offset)
    c, s = math.cos(yaw), math.sin(yaw)
    x, y = (TABLE_X[0] - robot.FINGERTIP_REACH - cfg.edge_clearance + cfg.slide, cfg.edge_y) \
        if needs_overhang(grasp) else (cfg.place_x, 0.0)
    return (x - (c * offset[0] - s * offset[1]), y - (s * offset[0] + c * offset[1]), TABLE_TOP_Z), yaw


def _check_task(model: str, grasp: Grasp, cfg: GraspCheckConfig) -> TaskSpec:
    pos, yaw = check_placement(grasp, cfg, model)
    return TaskSpec(family="grasp_check", task_id=0, condition="base", prompt="", seed=cfg.seed,
                    objects=(ObjectPlacement("object", model, pos, yaw),),
                    safety=SafetySpec("grasp_check", (), ()), image_size=default_image_size())


def _run(ctl: JointController, q_from: np.ndarray, traj: np.ndarray, grip: float) -> np.ndarray:
    for q in traj[1:]:
        ctl.apply(np.array([*q, grip]))
        ctl.step()
    return traj[-1] if len(traj) else q_from


def _hold(ctl: JointController, q: np.ndarray, grip: float, steps: int) -> None:
    for _ in range(steps):
        ctl.apply(np.array([*q, grip]))
        ctl.step()


def _fingers_touch(scene: Scene) -> bool:
    m, d = scene.model, scene.data
    obj = set(scene.object_geom_ids("object").tolist())
    touched = set()
    for c in d.contact[: d.ncon]:
        for a, b in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
            if b in obj:
                touched.add(m.body(m.geom_bodyid[a]).name)
    return all(f in touched for f in robot.FINGER_BODIES)


def check_grasp(model: str, grasp: Grasp, cfg: GraspCheckConfig) -> tuple[str, str]:
    """Run the check in a scene with the generator's physics; returns ``("valid" | "invalid", detail)``."""
    scene = build_scene(_check_task(model, grasp, cfg))
    scene.reset()
    planner = MotionPlanner(scene.model, load_motion_config())
    planner.sync(scene.data)
    ctl = JointController(scene)
    word = int.from_bytes(hashlib.sha256(grasp.id.encode()).digest()[:4], "little")
    rng = np.random.default_rng(np.random.SeedSequence([cfg.seed, word]))
    touch = AllowedContacts((("hand", "object"),))
    q = scene.arm_q()
    try:
        if needs_overhang(grasp):
            q = _push_to_edge(scene, planner, ctl, q, rng, cfg, grasp)
        world = grasp.world_matrix(scene.model, scene.data, "object")
        target = Pose.from_matrix(world)
        pre = Pose(target.pos - world[:3, 2] * cfg.standoff, target.quat)
        # as the edge pick: an edge pinch's pre-grasp IK from home first; its approach aimed at rest
        edge = needs_overhang(grasp)
        q_pre = first_ik(planner, pre, (robot.HOME_Q,), rng, collision_free=True) if edge else None
        if q_pre is None:
            q_pre = planner.ik(pre, q, rng, collision_free=True)
        if edge:
            target = resting_target(planner, scene.model, target, (q_pre,),
                                    np.random.default_rng(np.random.SeedSequence([cfg.seed, word, 1])))
        q = _run(ctl, q, planner.free(q, q_pre, rng).q, 0.0)
        planner.sync(scene.data)
        q = _run(ctl, q, planner.linear(q, target, rng, allowed=touch).q, 0.0)
    except MotionFailure as fail:
        return "invalid", f"unreachable in the check placement ({fail.stage}: {fail.reason})"
    _hold(ctl, q, 1.0, cfg.close_steps)
    art = get_model(model).articulation
    if grasp.frame and art is not None and art.kind == "slide":
        return _pull(scene, planner, ctl, q, rng, cfg)
    return _lift(scene, planner, ctl, q, rng, cfg)


def _push_to_edge(scene: Scene, planner: MotionPlanner, ctl: JointController, q: np.ndarray,
                  rng: np.random.Generator, cfg: GraspCheckConfig, grasp: Grasp) -> np.ndarray:
    """Slide the object towards the table's back edge (world -X) until ``grasp``'s fingertips clear it by
    ``edge_clearance``: the open hand, pointing down with its fingers spread along the edge, comes down
    ``push_clearance`` beyond the object's far side, fingertips ``push_tip_height`` above the table, and
    pushes in straight lines, guarded by the object's measured pose: each push (at most ``push_tries``) goes
    as far as the object still lacks (the pushing arm lags its command, so the next one adds what the last
    fell short), until it lacks less than ``push_tolerance``; then the hand rises."""
    start = push_start(scene, "object", cfg.push_tip_height, cfg.push_clearance)
    lift = np.array([0.0, 0.0, cfg.standoff])
    push = AllowedContacts((("hand", "object"), ("object", "table")))
    above = planner.ik(Pose(start.pos + lift, start.quat), q, rng, collision_free=True)
    q = _run(ctl, q, planner.free(q, above, rng).q, 0.0)
    q = _run(ctl, q, planner.linear(q, start, rng).q, 0.0)
    end, gap = start, cfg.push_clearance
    for _ in range(cfg.push_tries):
        lacking = shortfall(grasp.world_matrix(scene.model, scene.data, "object"), cfg.edge_clearance)
        if lacking < cfg.push_tolerance:
            break
        end = Pose(end.pos - np.array([gap + lacking, 0.0, 0.0]), start.quat)
        q = _run(ctl, q, planner.linear(q, end, rng, allowed=push).q, 0.0)
        _hold(ctl, q, 0.0, cfg.hold_steps)  # the arm catches up with its command
        gap = 0.0
    planner.sync(scene.data)
    q = _run(ctl, q, planner.linear(q, Pose(end.pos + lift, start.quat), rng, allowed=push).q, 0.0)
    planner.sync(scene.data)
    return q


def _lift(scene: Scene, planner: MotionPlanner, ctl: JointController, q: np.ndarray,
          rng: np.random.Generator, cfg: GraspCheckConfig) -> tuple[str, str]:
    """Lift the closed gripper straight up by ``lift``, hold, and judge rise, tilt and finger contact."""
    z0 = scene.object_pose("object")[0][2]
    tcp = Pose.from_pos_mat(*scene.tcp_pose())
    held = Attachment("object", (tcp.inverse() @ Pose.from_pos_mat(*scene.object_pose("object"))).matrix())
    planner.sync(scene.data)
    up = Pose(planner.fk(q).pos + np.array([0.0, 0.0, cfg.lift]), planner.fk(q).quat)
    try:
        q = _run(ctl, q, planner.linear(q, up, rng, allowed=AllowedContacts((("hand", "object"),
                                                                            ("object", "table"))),
                                        attached=held).q, 1.0)
    except MotionFailure as fail:
        return "invalid", f"cannot lift ({fail.stage}: {fail.reason})"
    _hold(ctl, q, 1.0, cfg.hold_steps)
    pos, rot = scene.object_pose("object")
    rise = float(pos[2] - z0)
    tilt = math.degrees(math.acos(min(1.0, float(rot[2, 2]))))
    touching = _fingers_touch(scene)
    detail = (f"lifted {rise * 100:.1f} of {cfg.lift * 100:.0f} cm, tilt {tilt:.1f}°, "
              f"fingers touch: {touching}")
    ok = rise >= cfg.min_lift_fraction * cfg.lift and touching and tilt <= cfg.max_tilt_deg
    return ("valid" if ok else "invalid"), detail


def _pull(scene: Scene, planner: MotionPlanner, ctl: JointController, q: np.ndarray,
          rng: np.random.Generator, cfg: GraspCheckConfig) -> tuple[str, str]:
    """Pull the closed gripper straight along the drawer's slide axis by ``pull``, hold, and judge how far
    the slide joint opened and finger contact."""
    m, d = scene.model, scene.data
    adr = scene.articulation_qpos_adr("object")
    joint = int(np.flatnonzero(m.jnt_qposadr == adr)[0])
    axis = d.xmat[m.jnt_bodyid[joint]].reshape(3, 3) @ m.jnt_axis[joint]  # world direction of +q
    q0 = float(d.qpos[adr])
    planner.sync(d)
    start = planner.fk(q)
    try:
        q = _run(ctl, q, planner.linear(q, Pose(start.pos + axis * cfg.pull, start.quat), rng,
                                        allowed=AllowedContacts((("hand", "object"),))).q, 1.0)
    except MotionFailure as fail:
        return "invalid", f"cannot pull ({fail.stage}: {fail.reason})"
    _hold(ctl, q, 1.0, cfg.hold_steps)
    opened = float(d.qpos[adr]) - q0
    touching = _fingers_touch(scene)
    detail = f"drawer opened {opened * 100:.1f} of {cfg.pull * 100:.0f} cm, fingers touch: {touching}"
    ok = opened >= cfg.min_pull_fraction * cfg.pull and touching
    return ("valid" if ok else "invalid"), detail
