"""Plain value types of the motion layer: poses, trajectories, contact rules, attachments, failures.

Quaternions are **(w, x, y, z)** throughout, as in MuJoCo (``data.xquat``) and mink's ``SO3.wxyz``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np


class MotionFailure(Exception):
    """A motion attempt failed; the engine records ``stage`` and ``reason`` and moves on.

    Not an :class:`~mgdata.errors.MgdataError`: the user's input is fine, this draw just did not work out.

    Attributes:
        stage: ``"ik_fail"``, ``"plan_fail"``, ``"retime_fail"``, ``"collision_recheck"``,
            ``"path_discontinuity"``, ``"start_invalid"``.
        reason: one human-readable sentence with the numbers that explain it.
    """

    def __init__(self, stage: str, reason: str) -> None:
        super().__init__(f"{stage}: {reason}")
        self.stage = stage
        self.reason = reason


@dataclass(frozen=True)
class Pose:
    """A rigid transform: ``pos`` (3,) in metres and unit quaternion ``quat`` (4,) as **(w, x, y, z)**.

    Example::

        pose = Pose.from_matrix(T)        # 4x4 homogeneous matrix
        T2 = pose.matrix()
        grasp_world = obj_pose @ grasp_local
    """

    pos: np.ndarray
    quat: np.ndarray

    def __post_init__(self) -> None:
        pos = np.array(self.pos, dtype=np.float64).reshape(3)
        quat = np.array(self.quat, dtype=np.float64).reshape(4)
        norm = float(np.linalg.norm(quat))
        if not np.isfinite(norm) or norm < 1e-9 or not np.all(np.isfinite(pos)):
            raise ValueError(f"Pose needs a finite position and a non-zero quaternion, got {pos}, {quat}")
        quat = quat / norm
        if quat[0] < 0:  # one canonical sign, so equal rotations compare equal
            quat = -quat
        object.__setattr__(self, "pos", pos)
        object.__setattr__(self, "quat", quat)

    @staticmethod
    def identity() -> Pose:
        return Pose(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))

    @staticmethod
    def from_matrix(matrix: np.ndarray) -> Pose:
        """From a 4x4 homogeneous transform (the rotation block must be orthonormal)."""
        T = np.asarray(matrix, dtype=np.float64)
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(T[:3, :3]).ravel())
        return Pose(T[:3, 3], quat)

    @staticmethod
    def from_pos_mat(pos: np.ndarray, mat: np.ndarray) -> Pose:
        """From a position and a 3x3 (or flat 9) rotation matrix, e.g. ``data.site_xpos/site_xmat``."""
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.asarray(mat, dtype=np.float64).ravel())
        return Pose(pos, quat)

    def rotation(self) -> np.ndarray:
        """The 3x3 rotation matrix."""
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, self.quat)
        return mat.reshape(3, 3)

    def matrix(self) -> np.ndarray:
        """The 4x4 homogeneous transform."""
        T = np.eye(4)
        T[:3, :3] = self.rotation()
        T[:3, 3] = self.pos
        return T

    def inverse(self) -> Pose:
        return Pose.from_matrix(np.linalg.inv(self.matrix()))

    def __matmul__(self, other: Pose) -> Pose:
        return Pose.from_matrix(self.matrix() @ other.matrix())

    def angle_to(self, other: Pose) -> float:
        """Rotation angle (rad) between the two orientations."""
        return float(2.0 * np.arccos(min(1.0, abs(float(np.dot(self.quat, other.quat))))))


@dataclass(frozen=True)
class JointTrajectory:
    """Arm joint targets sampled at a fixed control rate.

    Attributes:
        q: (N, 7) float64 joint positions; row 0 is the start, row N-1 the end, row k at time ``k / rate``
            (the last interval may be shorter: the end is reached exactly at ``duration``).
        rate: samples per second (the control rate, 20 Hz by default).
        duration: seconds from the first to the last sample.
    """

    q: np.ndarray
    rate: float
    duration: float

    def __post_init__(self) -> None:
        q = np.ascontiguousarray(self.q, dtype=np.float64)
        if q.ndim != 2 or q.shape[1] != 7 or q.shape[0] < 1:
            raise ValueError(f"JointTrajectory.q must be (N, 7) with N >= 1, got {q.shape}")
        q.setflags(write=False)
        object.__setattr__(self, "q", q)

    @property
    def times(self) -> np.ndarray:
        """(N,) sample times in seconds."""
        return np.minimum(np.arange(len(self.q)) / self.rate, self.duration)

    @property
    def start(self) -> np.ndarray:
        return self.q[0]

    @property
    def end(self) -> np.ndarray:
        return self.q[-1]

    def __len__(self) -> int:
        return len(self.q)

    def reversed(self) -> JointTrajectory:
        """The same samples played backwards (same timing, end first)."""
        return JointTrajectory(self.q[::-1].copy(), self.rate, self.duration)


@dataclass(frozen=True)
class AllowedContacts:
    """Contacts the collision checker tolerates, as pairs of body names.

    A pair ``(a, b)`` allows every contact between a geom in the subtree of body ``a`` and one in the
    subtree of body ``b`` (either order): ``("hand", "jar")`` lets the fingers and palm touch the jar and lid.

    Example::

        AllowedContacts((("hand", "jar"), ("jar", "table")))   # grasped jar leaving its support
    """

    pairs: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        pairs = tuple(tuple(p) for p in self.pairs)
        for pair in pairs:
            if len(pair) != 2 or not all(isinstance(n, str) and n for n in pair):
                raise ValueError(f"AllowedContacts pairs are (body, body) names, got {pair!r}")
        object.__setattr__(self, "pairs", pairs)

    def __add__(self, other: AllowedContacts) -> AllowedContacts:
        return AllowedContacts(self.pairs + other.pairs)


NO_CONTACTS = AllowedContacts()
"""The default: no contact involving the robot (or a held object) is allowed."""


@dataclass(frozen=True)
class Attachment:
    """A held object moving rigidly with the TCP while paths are checked.

    Its contacts with the gripper (palm, fingers), among its own parts and with its riders are ignored; its
    contacts with the rest of the robot and the world are checked like the robot's (inflated by the planning
    margin).

    Attributes:
        body: name of the object's root body; it must hang from a free joint.
        tcp_T_body: 4x4 pose of that body in the TCP frame (measured from the live state at grasp time).
        riders: other loose bodies carried along with it (the food in a jar); each keeps the pose relative
            to ``body`` that it has in the synced state.

    Example::

        Attachment("jar", (tcp_pose.inverse() @ jar_pose).matrix(), riders=("food",))
    """

    body: str
    tcp_T_body: np.ndarray = field(default_factory=lambda: np.eye(4))
    riders: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        T = np.array(self.tcp_T_body, dtype=np.float64)
        if T.shape != (4, 4):
            raise ValueError(f"Attachment.tcp_T_body must be 4x4, got {T.shape}")
        T.setflags(write=False)
        object.__setattr__(self, "tcp_T_body", T)
        object.__setattr__(self, "riders", tuple(self.riders))
