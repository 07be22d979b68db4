"""Edge pinches: a flat object's edge (a board's, a plate's rim) pinched where it overhangs the table's back
edge, behind the robot base (the one table edge the hand reaches from beyond it), after the open hand has
pushed the object there. The geometry the grasp check (:mod:`mgdata.grasps.check`) and the Layer 2
primitive (:mod:`mgdata.skeleton.edge_pick`) share.

Example::

    if needs_overhang(grasp):
        lacking = shortfall(grasp.world_matrix(model, data, "board"), clearance=0.005)   # m still to push
"""

from __future__ import annotations

import math

import numpy as np

from mgdata.grasps.db import Grasp
from mgdata.motion import Pose
from mgdata.sim import robot
from mgdata.sim.scene import Scene
from mgdata.sim.world import TABLE_TOP_Z, TABLE_X

PUSH_QUAT = np.array([0.0, 1.0, 0.0, 0.0])
"""The pushing hand's orientation: TCP +Z down, +X forward, the fingers spread along world Y."""
_CORNERS = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float).T


def needs_overhang(grasp: Grasp) -> bool:
    """Whether the grasp's open lower finger reaches below the object's base: the fingers close within 45° of
    vertical, low on a free object (a board's or a plate's edge), so the pinched edge must overhang a table
    edge first. A grasp in a link's frame (a drawer handle) never does."""
    local = grasp.matrix()
    vertical = abs(float(local[2, 1]))
    lowest = float(local[2, 3]) - vertical * (robot.GRIPPER_MAX_OPENING / 2.0 + robot.FINGER_DEPTH)
    return not grasp.frame and vertical >= math.cos(math.radians(45.0)) and lowest < 0.0


def faces_the_back_edge(grasp_world: np.ndarray, max_deg: float = 30.0) -> bool:
    """Whether a pinch (its world TCP matrix) comes in from behind the table's back edge: its approach points
    within ``max_deg`` of world +X."""
    approach = grasp_world[:3, 2]
    return float(approach[0]) >= math.cos(math.radians(max_deg)) * float(np.linalg.norm(approach[:2]))


def shortfall(grasp_world: np.ndarray, clearance: float) -> float:
    """How far (m) the object must still slide towards the back edge (world -X) for the pinch's fingertips
    (``FINGERTIP_REACH`` past the TCP along the approach) to clear the table's edge by ``clearance``."""
    tips = grasp_world[0, 3] + grasp_world[0, 2] * robot.FINGERTIP_REACH
    return float(tips - (TABLE_X[0] - clearance))


def push_start(scene: Scene, name: str, tip_height: float, clearance: float) -> Pose:
    """Where the push of ``name`` towards the back edge starts: the open hand (``PUSH_QUAT``) ``clearance``
    beyond the object's far side (world +X, from its geoms' bounding boxes), in line with its centre, the
    fingertips ``tip_height`` above the table."""
    m, d = scene.model, scene.data
    far = max(float((d.geom_xpos[g, 0] + d.geom_xmat[g, :3] @ (m.geom_aabb[g, :3, None]
                                                              + _CORNERS * m.geom_aabb[g, 3:, None])).max())
              for g in scene.object_geom_ids(name))
    pos = np.array([far + robot.FINGER_HALF_WIDTH + clearance, scene.object_pose(name)[0][1],
                    TABLE_TOP_Z + tip_height + robot.FINGERTIP_REACH])
    return Pose(pos, PUSH_QUAT.copy())
