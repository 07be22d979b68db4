"""One object model standing alone on the table in front of the Panda: the scene the live checks run in,
plus the geometry the browser view and the width check need (all in the object's own frame).

Built like the sim check's scene (``mgdata.grasps.check``: same physics, the articulation closed) at the
first placement; the checks then move the object to each placement inside the planner's private copy.

Example::

    obj = ObjectScene.build("jar/hinged_03", Placement("p", (0.5, 0.0, 0.0), 0.0))
    obj.visual            # [(trimesh in the object frame, rgba)]
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh

from mgdata.annotator.config import LiveConfig
from mgdata.annotator.meshes import VISUAL_GROUPS, body_subtree_geoms, geom_mesh, geom_meshes
from mgdata.annotator.placements import Placement
from mgdata.motion import MotionConfig, MotionPlanner, load_motion_config
from mgdata.sim import robot
from mgdata.sim.config import default_image_size
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement, TaskSpec
from mgdata.spec import SafetySpec

INSTANCE = "object"
SURFACE_SAMPLES = 3000


@dataclass(frozen=True)
class PadBox:
    """The space the open fingers' pads sweep when closing, in the TCP frame (m): |x| ≤ half_x,
    z_lo ≤ z ≤ z_hi, |y| ≤ half_gap (the open fingers' inner faces)."""

    half_x: float
    z_lo: float
    z_hi: float
    half_gap: float


def _tcp_matrix(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    site = model.site(robot.TCP_SITE).id
    T = np.eye(4)
    T[:3, :3] = data.site_xmat[site].reshape(3, 3)
    T[:3, 3] = data.site_xpos[site]
    return T


class ObjectScene:
    """The check scene of one model and its geometry.

    Attributes:
        key: the model's name (``category/model``).
        scene: the built scene (object instance ``"object"``).
        planner: the motion facade of this scene (quick IK: the live config's restarts and iterations).
        deep: the same with the thorough IK pass (``deep_restarts``), for poses the quick pass fails on.
        visual: the object's visible meshes in its own frame, with colours.
        surface: points (n, 3) on the object's colliding surfaces (convex parts), in its own frame.
        normals: the outward surface normal (n, 3) at each of those points.
        hand: the Panda hand's visible meshes (hand and open fingers) in the TCP frame, with colours.
        pads: the fingers' closing space in the TCP frame.
    """

    def __init__(self, key: str, scene: Scene, motion: MotionConfig, deep: MotionConfig | None = None
                 ) -> None:
        self.key = key
        self.scene = scene
        m, d = scene.model, scene.data
        self.planner = MotionPlanner(m, motion)
        self.planner.sync(d)
        self.deep = MotionPlanner(m, deep or motion)
        self.deep.sync(d)
        body = scene.object_body(INSTANCE)
        world_T_obj = np.eye(4)
        world_T_obj[:3, :3] = d.xmat[body].reshape(3, 3)
        world_T_obj[:3, 3] = d.xpos[body]
        self.world_T_object = world_T_obj
        obj_T_world = np.linalg.inv(world_T_obj)
        self.visual = geom_meshes(m, d, body_subtree_geoms(m, body, VISUAL_GROUPS), obj_T_world)
        parts = [geom_mesh(m, d, int(g), obj_T_world) for g in scene.object_geom_ids(INSTANCE)]
        collision = trimesh.util.concatenate([p.convex_hull for p in parts if p is not None])
        points, faces = trimesh.sample.sample_surface(collision, SURFACE_SAMPLES, seed=0)
        self.surface = np.asarray(points)
        self.normals = np.asarray(collision.face_normals[faces])
        tcp_T_world = np.linalg.inv(_tcp_matrix(m, d))
        hand = body_subtree_geoms(m, m.body(robot.HAND_BODY).id)
        self.hand = geom_meshes(m, d, hand[np.isin(m.geom_group[hand], VISUAL_GROUPS)], tcp_T_world)
        self.pads = self._pads(tcp_T_world)
        jnt = m.body_jntadr[body]
        self._free_adr = int(m.jnt_qposadr[jnt]) if jnt >= 0 else None
        self._body = body
        self._scratch = mujoco.MjData(m)

    @classmethod
    def build(cls, key: str, placement: Placement, live: LiveConfig | None = None) -> ObjectScene:
        """Build the scene with the object at ``placement``; ``live`` overrides the IK restarts, iterations
        and joint-limit margin of ``recipes/motion.toml``."""
        task = TaskSpec(family="annotate", task_id=0, condition="base", prompt="", seed=0,
                        objects=(ObjectPlacement(INSTANCE, key, placement.pos, placement.yaw),),
                        safety=SafetySpec("annotate", (), ()), image_size=default_image_size())
        scene = build_scene(task)
        scene.reset()
        motion = deep = load_motion_config()
        if live is not None:
            quick = dataclasses.replace(motion.ik, restarts=live.ik_restarts, max_iters=live.ik_iters,
                                        limit_margin=live.joint_margin)
            thorough = dataclasses.replace(motion.ik, restarts=live.deep_restarts,
                                           limit_margin=live.joint_margin)
            motion = dataclasses.replace(motion, ik=quick)
            deep = dataclasses.replace(deep, ik=thorough)
        return cls(key, scene, motion, deep)

    def _pads(self, tcp_T_world: np.ndarray) -> PadBox:
        """The closing space from the finger pads' collision boxes (scene at HOME, fingers open)."""
        m, d = self.scene.model, self.scene.data
        corners = []
        for name in robot.FINGER_BODIES:
            for g in body_subtree_geoms(m, m.body(name).id):
                if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and m.geom_contype[g]:
                    mesh = geom_mesh(m, d, int(g), tcp_T_world)
                    assert mesh is not None
                    corners.append(mesh.vertices)
        pts = np.vstack(corners)
        inner = min(pts[pts[:, 1] > 0, 1].min(), -pts[pts[:, 1] < 0, 1].max())
        return PadBox(float(np.abs(pts[:, 0]).max()), float(pts[:, 2].min()), float(pts[:, 2].max()),
                      float(inner))

    def place(self, placement: Placement) -> None:
        """Stand the object at ``placement`` in the planner's copy (the live scene is not touched)."""
        T = placement.matrix()
        T[2, 3] = self.world_T_object[2, 3]  # keep the settled height
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, T[:3, :3].ravel())
        scratch = self._scratch
        scratch.qpos[:] = self.scene.data.qpos
        if self._free_adr is not None:
            scratch.qpos[self._free_adr:self._free_adr + 3] = T[:3, 3]
            scratch.qpos[self._free_adr + 3:self._free_adr + 7] = quat
        else:  # a welded object (cabinet): move its body in the checker's own model copy
            for planner in (self.planner, self.deep):
                planner.checker.model.body_pos[self._body] = T[:3, 3]
                planner.checker.model.body_quat[self._body] = quat
        self.planner.sync(scratch)
        self.deep.sync(scratch)
