"""Camera placement: four fixed third-person views relative to the robot base, plus a wrist camera.

The third-person views follow the reference implementation's robot-frame views (reference §7), with
``fwd`` the robot's facing direction (+X rotated by the base yaw) and ``left`` = +Y rotated likewise; each
looks at the workspace point ``base + 0.45·fwd + 0.05·z``:

* ``front``    (the reference's "opposite"): ``base + 1.65·fwd + 0.9·z``, facing the robot;
* ``left`` / ``right``: ``base ± 1.0·left + 0.2·fwd + 0.9·z``;
* ``shoulder`` (left shoulder): ``base − 0.43·fwd + 0.55·left + 0.9·z``;
* ``wrist``: on the hand, beside the fingers, looking along the approach axis (hand +Z) past the fingertips.
"""

from __future__ import annotations

import mujoco
import numpy as np

THIRD_PERSON: tuple[str, ...] = ("front", "left", "right", "shoulder")
WRIST = "wrist"
CAMERA_NAMES: tuple[str, ...] = (*THIRD_PERSON, WRIST)
"""All cameras, in the order observations list them."""

FOVY_DEG = 58.0
WRIST_FOVY_DEG = 75.0
WORKSPACE_OFFSET = (0.45, 0.0, 0.22)
"""The point the third-person cameras look at, in the robot base frame (fwd, left, up)."""
_EYES = {
    "front": (1.65, 0.0, 0.9),
    "left": (0.2, 1.0, 0.9),
    "right": (0.2, -1.0, 0.9),
    "shoulder": (-0.43, 0.55, 0.9),
}
_WRIST_EYE = (0.08, 0.0, 0.0)
_WRIST_TARGET = (0.0, 0.0, 0.22)
"""Wrist camera eye and look-at point in the hand frame (hand +Z: approach axis; fingers open along Y)."""


def look_at_quat(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Quaternion (w, x, y, z) of a camera at ``eye`` looking at ``target`` (camera −Z forward, +Y up)."""
    fwd = np.asarray(target, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, fwd)
    mat = np.stack([right, cam_up, -fwd], axis=1)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, mat.ravel())
    return quat


def base_frame(base: tuple[float, float, float], yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and rotation matrix of the robot base."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.asarray(base, dtype=np.float64), np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def add_cameras(spec: mujoco.MjSpec, base: tuple[float, float, float], yaw: float, hand_body: str) -> None:
    """Add the five cameras to ``spec`` (third-person ones in the world, ``wrist`` on ``hand_body``)."""
    pos, rot = base_frame(base, yaw)
    target = pos + rot @ np.array(WORKSPACE_OFFSET)
    for name in THIRD_PERSON:
        eye = pos + rot @ np.array(_EYES[name])
        quat = look_at_quat(eye, target, np.array([0.0, 0.0, 1.0]))
        spec.worldbody.add_camera(name=name, pos=eye.tolist(), quat=quat.tolist(), fovy=FOVY_DEG)
    quat = look_at_quat(np.array(_WRIST_EYE), np.array(_WRIST_TARGET), np.array([1.0, 0.0, 0.0]))
    spec.body(hand_body).add_camera(name=WRIST, pos=list(_WRIST_EYE), quat=quat.tolist(), fovy=WRIST_FOVY_DEG)
