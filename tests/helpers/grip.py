"""A scripted close → lift → carry → hold of one object by one grasp of the grasp DB, measured from raw
MuJoCo data (not from mgdata's predicates or contact helpers): used by tests/sim/test_grip_force.py.

The object stands where the grasp check stands it (an edge pinch's object is first pushed over the table's
back edge by the check's own push, ``mgdata.grasps.check``); the planner (a test fixture here, not the code
under test) reaches the pre-grasp and the grasp, the gripper closes for ``close_steps`` control steps, the
hand lifts 10 cm, carries 15 cm sideways and holds still for ``hold_s`` seconds. Measured:

* ``rise`` (m): the object's height gain, from ``data.xpos`` of its root body;
* ``max_tilt_deg``: the largest angle between the object's +Z and world +Z during lift, carry and hold;
* ``slip_hold`` (m): how far the object moved in the TCP frame (``data.site_xpos``/``site_xmat``) over the
  hold;
* ``max_penetration`` (m): the deepest finger–object contact (``-data.contact.dist``) over the attempt;
* ``pad_force`` (N, per finger): the summed normal force of ``mujoco.mj_contactForce`` between each finger
  body and the object at the end;
* ``max_external`` (N): the largest entry of ``xfrc_applied``/``qfrc_applied`` seen at any step (must be 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from mgdata.grasps.check import GraspCheckConfig, _check_task, _push_to_edge
from mgdata.grasps.db import GraspDB
from mgdata.grasps.edge import needs_overhang
from mgdata.motion import AllowedContacts, Attachment, MotionPlanner, Pose, load_motion_config
from mgdata.paths import grasps_dir
from mgdata.sim import robot
from mgdata.sim.assets import get_model
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from tests.helpers.sim_tasks import ik, task_with

DOWN = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
"""TCP rotation pointing straight down, fingers closing along world Y."""


def pad_forces(m: mujoco.MjModel, d: mujoco.MjData, obj_body: int) -> tuple[float, float]:
    """Summed normal force (N) of the contacts between each finger body and the object (raw
    mj_contactForce)."""
    force, out = np.zeros(6), [0.0, 0.0]
    fingers = [m.body(b).id for b in robot.FINGER_BODIES]
    for i, c in enumerate(d.contact[: d.ncon]):
        bodies = (int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2]))
        for k, f in enumerate(fingers):
            if f in bodies and obj_body in bodies:
                mujoco.mj_contactForce(m, d, i, force)
                out[k] += float(force[0])
    return out[0], out[1]


def carton_between_pads() -> tuple[Scene, JointController, np.ndarray]:
    """A carton on the table with the open hand lowered around it (pointing down): ``(scene, controller,
    arm configuration)``, ready to close."""
    box = get_model("box/carton_03")
    hz = box.geometry["half_extents"][2]
    scene = build_scene(task_with(ObjectPlacement("box", box.name, (0.5, 0.0, 0.0))))
    scene.reset()
    ctl = JointController(scene)
    q = robot.HOME_Q
    for z in np.linspace(2 * hz + 0.1, 2 * hz - 0.03, 15):
        q = ik(q, (0.5, 0.0, z), DOWN)
        ctl.apply(np.array([*q, 0.0]))
        ctl.step()
    return scene, ctl, q


@dataclass
class GripRun:
    rise: float
    max_tilt_deg: float
    slip_hold: float
    max_penetration: float
    pad_force: tuple[float, float]
    max_external: float


def scripted_grip(model: str, grasp_id: str, *, close_steps: int = 20, hold_s: float = 5.0) -> GripRun:
    """Close on ``model`` (``category/model``) with grasp ``grasp_id``, lift, carry, hold; measure raw."""
    grasp = next(g for g in GraspDB.load_dir(grasps_dir()).grasps(model) if g.id == grasp_id)
    cfg = GraspCheckConfig()
    scene = build_scene(_check_task(model, grasp, cfg))
    scene.reset()
    m, d = scene.model, scene.data
    planner = MotionPlanner(m, load_motion_config())
    planner.sync(d)
    ctl = JointController(scene)
    rng = np.random.default_rng(0)
    obj_body = m.body("object").id
    obj_geoms = np.flatnonzero(m.body_rootid[m.geom_bodyid] == obj_body)
    fingers = [m.body(b).id for b in robot.FINGER_BODIES]
    tcp = m.site(robot.TCP_SITE).id
    worst = {"pen": 0.0, "ext": 0.0, "tilt": 0.0}
    track_tilt = [False]

    def tilt() -> float:
        return math.degrees(math.acos(min(1.0, float(d.xmat[obj_body].reshape(3, 3)[2, 2]))))

    def measure() -> None:
        for c in d.contact[: d.ncon]:
            pair = {m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]}
            if (c.geom1 in obj_geoms or c.geom2 in obj_geoms) and pair & set(fingers):
                worst["pen"] = max(worst["pen"], -float(c.dist))
        worst["ext"] = max(worst["ext"], float(np.abs(d.xfrc_applied).max()),
                           float(np.abs(d.qfrc_applied).max()))
        if track_tilt[0]:
            worst["tilt"] = max(worst["tilt"], tilt())

    def step(q: np.ndarray, grip: float) -> None:
        ctl.apply(np.array([*q, grip]))
        ctl.step()
        measure()

    def run(traj: np.ndarray, grip: float) -> np.ndarray:
        for q in traj[1:]:
            step(q, grip)
        return traj[-1]

    def in_tcp() -> np.ndarray:
        return d.site_xmat[tcp].reshape(3, 3).T @ (d.xpos[obj_body] - d.site_xpos[tcp])

    q = scene.arm_q()
    if needs_overhang(grasp):
        q = _push_to_edge(scene, planner, ctl, q, rng, cfg, grasp)
    world = grasp.world_matrix(m, d, "object")
    target = Pose.from_matrix(world)
    pre = Pose(target.pos - world[:3, 2] * cfg.standoff, target.quat)
    q = run(planner.free(q, planner.ik(pre, q, rng, collision_free=True), rng).q, 0.0)
    planner.sync(d)
    q = run(planner.linear(q, target, rng, allowed=AllowedContacts((("hand", "object"),))).q, 0.0)
    for _ in range(close_steps):
        step(q, 1.0)
    z0 = float(d.xpos[obj_body][2])
    hand = Pose.from_pos_mat(*scene.tcp_pose())
    held = Attachment("object", (hand.inverse() @ Pose.from_pos_mat(*scene.object_pose("object"))).matrix())
    allow = AllowedContacts((("hand", "object"), ("object", "table")))
    track_tilt[0] = True
    for offset in ((0.0, 0.0, 0.10), (0.0, 0.15, 0.0)):
        planner.sync(d)
        start = planner.fk(q)
        goal = Pose(start.pos + np.array(offset), start.quat)
        q = run(planner.linear(q, goal, rng, allowed=allow, attached=held).q, 1.0)
    before = in_tcp()
    for _ in range(round(hold_s / scene.physics.control_dt)):
        step(q, 1.0)
    slip = float(np.linalg.norm(in_tcp() - before))
    pads = [0.0, 0.0]
    force = np.zeros(6)
    for i, c in enumerate(d.contact[: d.ncon]):
        bodies = (m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2])
        for k, f in enumerate(fingers):
            if f in bodies and (c.geom1 in obj_geoms or c.geom2 in obj_geoms):
                mujoco.mj_contactForce(m, d, i, force)
                pads[k] += float(force[0])
    return GripRun(rise=float(d.xpos[obj_body][2]) - z0, max_tilt_deg=worst["tilt"], slip_hold=slip,
                   max_penetration=worst["pen"], pad_force=(pads[0], pads[1]), max_external=worst["ext"])


def source_files() -> list[Path]:
    """Every Python file of the package and the teleop tools."""
    root = Path(__file__).resolve().parents[2]
    return sorted([*(root / "mgdata").rglob("*.py"), *(root / "teleop").rglob("*.py")])
