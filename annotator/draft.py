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


def ray_hit(origin: np.ndarray, direction: np.ndarray, vertices: np.ndarray, faces: np.ndarray
            ) -> np.ndarray | None:
    """The nearest point where a ray meets a triangle mesh (Möller–Trumbore over all triangles), or None."""
    o, d = np.asarray(origin, float), np.asarray(direction, float)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    t_vec = o - a
    u = np.einsum("ij,ij->i", t_vec, p) * inv
    q = np.cross(t_vec, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
    if not hit.any():
        return None
    return o + d * float(t[hit].min())
