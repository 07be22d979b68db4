"""Guided-mode pose construction: a surface point, an approach preset, a roll (yaw) about the approach and
a depth give the TCP pose in the object frame.

* the base orientation is a preset or, after free mode, the pose the user left it in (so switching modes
  keeps the pose); approach (gripper +Z, the direction the hand moves in): ``top-down`` = −Z;
  ``side from +X`` = −X (the hand comes from the +X side), and likewise for −X, +Y, −Y;
* fingers (gripper ±Y) close horizontally for side presets and along the object's Y for top-down, then the
  hand is rolled by ``yaw`` degrees about the approach;
* the TCP sits ``depth`` metres past the surface point along the approach (positive: into the object).

Example::

    pose = guided_pose(np.array([0.035, 0.0, 0.06]), preset_frame("side from +X"), yaw_deg=0.0, depth=0.02)
"""

from __future__ import annotations

import math

import numpy as np

from mgdata.motion import Pose

PRESETS: dict[str, tuple[float, float, float]] = {
    "top-down": (0.0, 0.0, -1.0),
    "side from +X": (-1.0, 0.0, 0.0),
    "side from -X": (1.0, 0.0, 0.0),
    "side from +Y": (0.0, -1.0, 0.0),
    "side from -Y": (0.0, 1.0, 0.0),
}


def preset_frame(preset: str) -> np.ndarray:
    """Rotation (3x3, columns = gripper x, y, z) of a preset at yaw 0."""
    z = np.array(PRESETS[preset])
    y = np.array([0.0, 1.0, 0.0]) if preset == "top-down" else np.cross(np.array([0.0, 0.0, 1.0]), z)
    y /= np.linalg.norm(y)
    return np.stack([np.cross(y, z), y, z], axis=1)


def guided_pose(contact: np.ndarray, base: np.ndarray, yaw_deg: float, depth: float) -> Pose:
    """TCP pose in the object frame for a surface point, a base orientation (a preset's
    :func:`preset_frame`, or the pose the user came from), a roll about its approach (deg) and a depth (m)."""
    a = math.radians(yaw_deg)
    roll = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    rot = base @ roll
    return Pose.from_pos_mat(np.asarray(contact, dtype=float) + rot[:, 2] * depth, rot)


def ray_hit(origin: np.ndarray, direction: np.ndarray, mesh) -> np.ndarray | None:
    """The first point where a ray meets a trimesh (object frame), or None."""
    locations, _, _ = mesh.ray.intersects_location([origin], [direction], multiple_hits=True)
    if len(locations) == 0:
        return None
    d = (locations - origin) @ np.asarray(direction)
    return locations[int(np.argmin(np.where(d >= 0, d, np.inf)))]
