"""Camera placement: four fixed third-person views relative to the robot base, plus a wrist camera.

The third-person views follow the reference implementation's robot-frame views (reference §7), with
``fwd`` the robot's facing direction (+X rotated by the base yaw) and ``left`` = +Y rotated likewise; each
looks at the workspace point ``base + 0.45·fwd + 0.22·z``. The shipped placements (:class:`CameraLayout`,
``recipes/sim.toml`` ``[cameras]``; (fwd, left, up) offsets from the base):

* ``front``    (the reference's "opposite"): ``base + 1.65·fwd + 0.9·z``, facing the robot;
* ``left`` / ``right``: ``base ± 1.0·left + 0.2·fwd + 0.9·z``;
* ``shoulder`` (left shoulder): ``base − 0.43·fwd + 0.55·left + 0.9·z``;
* ``wrist``: where a real Franka wrist camera sits: a RealSense-sized body (90 × 25 × 25 mm) on the hand's
  −X face at the flange, behind the fingers, looking along the approach axis (hand +Z) at the fingertips.
  The camera body is a colliding robot geom (``wrist_camera``), so planning keeps it out of the table and
  the objects like any other link, and the eye sits on its front face: the eye is never inside geometry,
  and never below the table top.

The camera names are a contract (observations list them); only their placement is tunable. A family
recipe may reframe its four third-person views with its own ``[cameras]`` table (:data:`FAMILY_KEYS`:
``fovy``, ``look_at`` and the four eyes, over ``sim.toml``'s), so each family's work fills its frames; the
wrist camera is the robot's and stays. ``benchmarks/fit_framing.py`` derives such a table from the family's
layouts, and ``benchmarks/bench_framing.py`` measures it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np

from mgdata.errors import RecipeError
from mgdata.settings import coerce_value

THIRD_PERSON: tuple[str, ...] = ("front", "left", "right", "shoulder")
WRIST = "wrist"
WRIST_BODY_GEOM = "wrist_camera"
"""Name of the wrist camera's body geom (a box on the hand)."""
CAMERA_NAMES: tuple[str, ...] = (*THIRD_PERSON, WRIST)
"""All cameras, in the order observations list them."""

Vec3 = tuple[float, float, float]
FAMILY_KEYS: tuple[str, ...] = ("fovy", "look_at", *THIRD_PERSON)
"""The keys a family recipe's ``[cameras]`` table may set: how its third-person views are framed."""


@dataclass(frozen=True)
class CameraLayout:
    """Where the cameras sit and how wide they see (``recipes/sim.toml`` ``[cameras]``).

    Attributes:
        fovy, wrist_fovy: vertical field of view of the third-person cameras and of the wrist camera (deg).
        look_at: the point the third-person cameras look at, in the robot base frame (fwd, left, up; m).
        front, left, right, shoulder: each third-person camera's eye in the robot base frame (m).
        wrist_eye, wrist_target: the wrist camera's eye and look-at point in the hand frame (hand +Z: the
            approach axis; the fingers open along Y; the hand's own shell spans x ∈ ±0.032 m).
        wrist_body: half extents (m) of the wrist camera's body, a box in the hand frame whose front face
            (+Z) is centred on ``wrist_eye``.
        image_size: default image side (pixels) where a recipe or task does not set one.
    """

    fovy: float = 58.0
    wrist_fovy: float = 75.0
    look_at: Vec3 = (0.45, 0.0, 0.22)
    front: Vec3 = (1.65, 0.0, 0.9)
    left: Vec3 = (0.2, 1.0, 0.9)
    right: Vec3 = (0.2, -1.0, 0.9)
    shoulder: Vec3 = (-0.43, 0.55, 0.9)
    wrist_eye: Vec3 = (-0.05, 0.0, 0.03)
    wrist_target: Vec3 = (0.0, 0.0, 0.2)
    wrist_body: Vec3 = (0.0125, 0.045, 0.0125)
    image_size: int = 256

    def __post_init__(self) -> None:
        for key in ("fovy", "wrist_fovy"):
            if not 0.0 < getattr(self, key) < 180.0:
                raise RecipeError(f"[cameras] {key} = {getattr(self, key)!r}: expected degrees in (0, 180)")
        if self.image_size < 8:
            raise RecipeError(f"[cameras] image_size = {self.image_size!r}: expected an integer >= 8")
        for key in THIRD_PERSON:
            view = np.subtract(self.look_at, getattr(self, key))
            if np.hypot(view[0], view[1]) < 1e-6:
                raise RecipeError(f"[cameras] {key} = {list(getattr(self, key))}: the camera must not stand "
                                  f"straight above or below look_at = {list(self.look_at)}")
        if min(self.wrist_body) <= 0.0:
            raise RecipeError(f"[cameras] wrist_body = {list(self.wrist_body)}: expected three half extents "
                              "> 0 (m)")
        view = np.subtract(self.wrist_target, self.wrist_eye)
        if np.hypot(view[1], view[2]) < 1e-6:
            raise RecipeError(f"[cameras] wrist_target = {list(self.wrist_target)}: expected a point away "
                              f"from wrist_eye = {list(self.wrist_eye)}, not along the hand's X axis")

    def eye(self, name: str) -> Vec3:
        """The eye of third-person camera ``name`` in the robot base frame."""
        if name not in THIRD_PERSON:
            raise ValueError(f"{name!r} is not a third-person camera; expected one of {THIRD_PERSON}")
        return getattr(self, name)


def parse_family_cameras(table: Mapping[str, Any], base: CameraLayout, where: str) -> Mapping[str, Any]:
    """A family recipe's ``[cameras]`` table, checked (keys from :data:`FAMILY_KEYS`, types, and the layout
    it makes over ``base``): the overrides, read-only, as :func:`with_overrides` takes them."""
    unknown = sorted(set(table) - set(FAMILY_KEYS))
    if unknown:
        raise RecipeError(f"{where} unknown key(s) {unknown}; a family may set {list(FAMILY_KEYS)} (the "
                          "wrist camera and the image size are not a family's: recipes/sim.toml, [tasks])")
    types = {f.name: str(f.type) for f in dataclasses.fields(CameraLayout)}
    values = {k: coerce_value(v, types[k], f"{where} {k}") for k, v in table.items()}
    try:
        with_overrides(base, values)
    except RecipeError as err:
        raise RecipeError(f"{where} {str(err).removeprefix('[cameras] ')}") from None
    return MappingProxyType(values)


def with_overrides(layout: CameraLayout, overrides: Mapping[str, Any]) -> CameraLayout:
    """``layout`` with a family's ``[cameras]`` overrides (:func:`parse_family_cameras`) applied."""
    return dataclasses.replace(layout, **overrides) if overrides else layout


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


def camera_poses(base: tuple[float, float, float], yaw: float,
                 layout: CameraLayout) -> dict[str, tuple[np.ndarray, np.ndarray, float]]:
    """Each camera's (position, quaternion w-x-y-z, fovy): the third-person ones in the world frame of a robot
    base at ``base`` turned by ``yaw``, ``wrist`` in the hand frame. :func:`add_cameras` places them; a
    benchmark can apply another layout to a compiled model's ``cam_pos``/``cam_quat``/``cam_fovy``."""
    pos, rot = base_frame(base, yaw)
    target = pos + rot @ np.array(layout.look_at)
    poses = {}
    for name in THIRD_PERSON:
        eye = pos + rot @ np.array(layout.eye(name))
        poses[name] = (eye, look_at_quat(eye, target, np.array([0.0, 0.0, 1.0])), layout.fovy)
    quat = look_at_quat(np.array(layout.wrist_eye), np.array(layout.wrist_target), np.array([1.0, 0.0, 0.0]))
    poses[WRIST] = (np.array(layout.wrist_eye, dtype=np.float64), quat, layout.wrist_fovy)
    return poses


def add_cameras(spec: mujoco.MjSpec, base: tuple[float, float, float], yaw: float, hand_body: str,
                layout: CameraLayout) -> None:
    """Add the five cameras to ``spec`` (third-person ones in the world; ``wrist`` and its colliding body
    geom on ``hand_body``)."""
    poses = camera_poses(base, yaw, layout)
    for name in THIRD_PERSON:
        eye, quat, fovy = poses[name]
        spec.worldbody.add_camera(name=name, pos=eye.tolist(), quat=quat.tolist(), fovy=fovy)
    eye, quat, fovy = poses[WRIST]
    hand = spec.body(hand_body)
    hand.add_camera(name=WRIST, pos=eye.tolist(), quat=quat.tolist(), fovy=fovy)
    centre = np.array(layout.wrist_eye) - np.array([0.0, 0.0, layout.wrist_body[2]])
    hand.add_geom(name=WRIST_BODY_GEOM, type=mujoco.mjtGeom.mjGEOM_BOX, size=list(layout.wrist_body),
                  pos=centre.tolist(), rgba=[0.16, 0.16, 0.18, 1.0], group=2, mass=0.0)
