"""Pose idioms of skeletons: backing off along the approach axis, straight up, yaw about the vertical, a
rotation about an axis, and the held object's pose in the TCP frame.

Example::

    pre = backed_off(grasp_tcp, 0.08)                 # 8 cm back along the TCP's +Z (its approach axis)
    lift = raised(ctx.commanded_tcp(), 0.1)           # 10 cm straight up
    turned = Pose(np.zeros(3), about_z(math.pi / 2)) @ obj_pose
    held = held_object(ctx, "jar")                     # held.in_tcp, held.attachment
    tcp_target = held.tcp_for(where_the_jar_should_be)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mgdata.motion.types import Attachment, Pose

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context

UP = np.array([0.0, 0.0, 1.0])
"""World +Z."""


def backed_off(pose: Pose, distance: float) -> Pose:
    """``pose`` moved ``distance`` m back along its own +Z (a TCP's approach axis), orientation kept.

    >>> backed_off(Pose(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])), 0.1).pos.tolist()
    [0.0, 0.0, -0.1]
    """
    return Pose(pose.pos - pose.rotation()[:, 2] * distance, pose.quat)


def raised(pose: Pose, height: float) -> Pose:
    """``pose`` moved ``height`` m straight up (world +Z), orientation kept.

    >>> raised(Pose(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])), 0.2).pos.tolist()
    [0.0, 0.0, 0.2]
    """
    return Pose(pose.pos + np.array([0.0, 0.0, height]), pose.quat)


def about_z(yaw: float) -> np.ndarray:
    """The quaternion (w, x, y, z) of a turn by ``yaw`` rad about world +Z.

    >>> about_z(math.pi).round(6).tolist()
    [0.0, 0.0, 0.0, 1.0]
    """
    return np.array([math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)])


def yaw_of(pose: Pose) -> float:
    """The heading (rad) of ``pose``'s x axis about world +Z.

    >>> round(yaw_of(Pose(np.zeros(3), about_z(0.5))), 6)
    0.5
    """
    rot = pose.rotation()
    return math.atan2(rot[1, 0], rot[0, 0])


def upright(quat: np.ndarray) -> np.ndarray:
    """The turn about world +Z closest to ``quat``: the object stood upright again, its heading kept."""
    return about_z(yaw_of(Pose(np.zeros(3), quat)))


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` rad about ``axis`` (any length; Rodrigues' formula).

    >>> rotation_about(UP, math.pi / 2).round(6).tolist()[0]
    [0.0, -1.0, 0.0]
    """
    a = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


@dataclass(frozen=True)
class Held:
    """An object in the hand: its pose in the TCP frame and its attachment for the planner.

    Attributes:
        in_tcp: the object's pose in the TCP frame.
        attachment: the planner's attachment (the object moves with the TCP in collision checks).
    """

    in_tcp: Pose
    attachment: Attachment

    def tcp_for(self, obj: Pose) -> Pose:
        """The TCP pose that puts the held object at world pose ``obj``."""
        return obj @ self.in_tcp.inverse()


def held_object(ctx: Context, obj: str, *, tcp: Pose | None = None, pose: Pose | None = None,
                riders: tuple[str, ...] = ()) -> Held:
    """The object ``obj`` as held now: its pose (or ``pose``) relative to the measured TCP (or to ``tcp``),
    with the loose bodies ``riders`` carried along."""
    in_tcp = (tcp or ctx.tcp_pose()).inverse() @ (pose or ctx.object_pose(obj))
    return Held(in_tcp, Attachment(obj, in_tcp.matrix(), riders=riders))


def horizontal_unit(v: np.ndarray) -> np.ndarray:
    """The horizontal part (x, y) of ``v``, unit length (zero if ``v`` is vertical).

    >>> horizontal_unit(np.array([3.0, 4.0, 9.0])).tolist()
    [0.6, 0.8]
    """
    n = float(np.hypot(v[0], v[1]))
    return np.zeros(2) if n < 1e-9 else np.array([v[0], v[1]]) / n
