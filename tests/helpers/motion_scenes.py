"""Test scenes for the motion layer: the Panda on a table, optionally with a wall and a loose box.

Built from ``mgdata.sim.robot.load_panda_spec`` with ``MjSpec`` so the tests do not depend on the family scene
builder. Frames: robot base at the origin, table top at z = 0, the wall across y = 0 in front of the robot.
"""

from __future__ import annotations

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)

# isort: split
import mujoco
import numpy as np

from mgdata.motion import Pose
from mgdata.sim.robot import HOME_Q, ROOT_BODY, load_panda_spec

TOP_DOWN = np.array([0.0, 1.0, 0.0, 0.0])
"""TCP pointing straight down (w, x, y, z): 180° about world X."""

WALL_X, WALL_HALF = 0.5, (0.15, 0.015, 0.15)
"""Wall centre x and half sizes: 30 cm long (x 0.35–0.65), 3 cm thick, 30 cm high on the table."""

BOX_HALF = 0.02


def scene(wall: bool = True, box: bool = False, base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0),
          base_yaw: float = 0.0) -> mujoco.MjModel:
    """Panda + table (top at z = 0, x 0.2–1.0) [+ wall on the table at y = 0] [+ a free 4 cm cube "box"].

    ``base_pos``/``base_yaw`` move the robot's root body (to test scenes whose base is not the world origin).
    """
    spec = load_panda_spec()
    base = spec.body(ROOT_BODY)
    base.pos = list(base_pos)
    base.quat = [np.cos(base_yaw / 2), 0.0, 0.0, np.sin(base_yaw / 2)]
    table = spec.worldbody.add_body(name="table", pos=[0.6, 0.0, -0.02])
    table.add_geom(name="table_top", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.4, 0.6, 0.02])
    if wall:
        body = spec.worldbody.add_body(name="wall", pos=[WALL_X, 0.0, WALL_HALF[2]])
        body.add_geom(name="wall", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(WALL_HALF))
    if box:
        body = spec.worldbody.add_body(name="box", pos=[0.45, 0.25, BOX_HALF])
        body.add_freejoint()
        body.add_geom(name="box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[BOX_HALF] * 3, mass=0.1)
    return spec.compile()


def home_data(model: mujoco.MjModel) -> mujoco.MjData:
    """Data at HOME_Q with the gripper open, kinematics computed."""
    data = mujoco.MjData(model)
    data.qpos[:7] = HOME_Q
    data.qpos[7:9] = 0.04
    mujoco.mj_forward(model, data)
    return data


def down_pose(x: float, y: float, z: float) -> Pose:
    """A top-down TCP pose at (x, y, z)."""
    return Pose(np.array([x, y, z]), TOP_DOWN)
