"""Collision checking of arm configurations in a private copy of the scene.

The checker owns a copy of the scene's ``MjModel`` and its own ``MjData``: the live simulation is never
touched. :meth:`CollisionChecker.sync` copies the world state (object poses, finger opening) in; each check
then writes the seven arm joints (and the pose of a held object, which moves rigidly with the TCP), runs
``mj_kinematics`` + ``mj_collision`` and judges every contact that involves a *moving* geom — a robot geom or
a held-object geom:

* moving ↔ world: invalid when closer than the query's margin (the planning margin while planning, 0 on the
  exact recheck);
* robot ↔ robot and robot ↔ held object: invalid when closer than ``self_margin``; contacts inside the
  gripper (palm and fingers touching each other) and between the gripper and the object it holds are ignored;
* pairs named in :class:`~mgdata.motion.types.AllowedContacts` are ignored;
* pairs already within the margin at the start or goal of a query are judged exactly (penetration only), so a
  motion may leave a configuration that sits close to a surface without granting it any real contact.

Each rule set becomes one (ngeom, ngeom) matrix of distance thresholds, so judging a check's contacts is one
gather and one comparison. The copy's contact bitmasks are remapped so that MuJoCo never even generates
world ↔ world contacts (objects resting on the table, food in a jar), while every pair with a moving geom
collides exactly when it would in the scene.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.motion.config import CheckConfig
from mgdata.motion.types import AllowedContacts, Attachment
from mgdata.sim.robot import HAND_BODY, TCP_SITE, arm_qpos_adr, robot_geom_ids

WORLD, ROBOT, GRIPPER, HELD = 0, 1, 2, 3


@dataclass(frozen=True)
class Contact:
    """A contact the checker judged invalid (for failure reasons)."""

    body1: str
    body2: str
    dist: float

    def __str__(self) -> str:
        return f"{self.body1} <-> {self.body2} (distance {self.dist * 1000:+.1f} mm)"


class CollisionChecker:
    """Validity of arm configurations against a snapshot of the scene.

    Example::

        checker = CollisionChecker(model, CheckConfig())
        checker.sync(data)
        checker.configure(allowed=AllowedContacts((("hand", "jar"),)), attached=None, margin=0.01)
        ok = checker.valid(q)
    """

    def __init__(self, model: mujoco.MjModel, config: CheckConfig) -> None:
        self.config = config
        self.model = copy.copy(model)
        # The midphase tests multi-geom bodies with bounding volumes fixed at compile time, which ignore the
        # margins set here at run time; without it every geom pair is bounded with its current margin.
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MIDPHASE
        self.data = mujoco.MjData(self.model)
        self._arm_adr = arm_qpos_adr(model)
        self._tcp = model.site(TCP_SITE).id
        self._base_margin = model.geom_margin.copy()
        self._base_contype = model.geom_contype.copy()
        self._base_conaffinity = model.geom_conaffinity.copy()
        robot_geoms = robot_geom_ids(model)
        self._kind0 = np.full(model.ngeom, WORLD, dtype=np.int8)
        self._kind0[robot_geoms] = ROBOT
        in_hand = np.isin(model.geom_bodyid[robot_geoms], self._subtree(model.body(HAND_BODY).id))
        self._kind0[robot_geoms[in_hand]] = GRIPPER
        self._kind = self._kind0.copy()
        self._allowed = np.zeros((model.ngeom, model.ngeom), dtype=bool)
        self._exact = np.zeros_like(self._allowed)
        self._threshold = np.zeros((model.ngeom, model.ngeom))
        self._margin = 0.0
        self._attached: Attachment | None = None
        self._carried: list[tuple[int, np.ndarray]] = []  # (free-joint qpos address, held_T_body)
        self._synced_qpos = self.data.qpos.copy()
        self.n_checks = 0
        self.configure(AllowedContacts(), None, 0.0)

    # ----------------------------------------------------------------------------------------- set-up
    def _subtree(self, body: int) -> np.ndarray:
        """Ids of ``body`` and all its descendants (MuJoCo numbers children after their parents)."""
        inside = np.zeros(self.model.nbody, dtype=bool)
        inside[body] = True
        for b in range(body + 1, self.model.nbody):
            inside[b] = inside[self.model.body_parentid[b]]
        return np.flatnonzero(inside)

    def _body_id(self, name: str, what: str) -> int:
        bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if bid < 0:
            names = sorted(self.model.body(i).name for i in range(1, self.model.nbody))
            raise SceneError(f"{what} names body {name!r}, which the scene does not have; bodies: {names}")
        return bid

    def _subtree_geoms(self, name: str, what: str) -> np.ndarray:
        bodies = self._subtree(self._body_id(name, what))
        return np.flatnonzero(np.isin(self.model.geom_bodyid, bodies))

    def sync(self, data: mujoco.MjData) -> None:
        """Copy the live world state (all joint positions, mocap poses) into the checker."""
        self._synced_qpos = data.qpos.copy()
        self.data.qpos[:] = data.qpos
        self.data.mocap_pos[:] = data.mocap_pos
        self.data.mocap_quat[:] = data.mocap_quat

    def configure(self, allowed: AllowedContacts, attached: Attachment | None, margin: float) -> None:
        """Set the rules of the next queries: allowed pairs, held object, and the world margin (m).

        Also forgets the pairs relaxed by :meth:`relax_pairs_at` and puts every body back at its synced pose.
        """
        self.data.qpos[:] = self._synced_qpos
        n = self.model.ngeom
        self._allowed = np.zeros((n, n), dtype=bool)
        for a, b in allowed.pairs:
            ga = self._subtree_geoms(a, "AllowedContacts")
            gb = self._subtree_geoms(b, "AllowedContacts")
            self._allowed[np.ix_(ga, gb)] = True
            self._allowed[np.ix_(gb, ga)] = True
        self._exact = np.zeros((n, n), dtype=bool)
        self._kind = self._kind0.copy()
        self._attached = attached
        self._carried = []
        if attached is not None:
            held = self._free_qpos_adr(attached.body)
            world_T_held = _free_pose(self.data.qpos, held)
            self._carried.append((held, np.eye(4)))
            for rider in attached.riders:
                adr = self._free_qpos_adr(rider)
                self._carried.append((adr, np.linalg.solve(world_T_held, _free_pose(self.data.qpos, adr))))
            for name in (attached.body, *attached.riders):
                self._kind[self._subtree_geoms(name, "Attachment")] = HELD
        self._remap_masks()
        self.set_margin(margin)

    def _free_qpos_adr(self, name: str) -> int:
        """qpos address of the free joint of loose body ``name``."""
        body = self._body_id(name, "Attachment")
        jnt = self.model.body_jntadr[body]
        if (self.model.body_parentid[body] != 0 or jnt < 0
                or self.model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE):
            raise SceneError(f"Attachment body {name!r} must be a child of the world with a free joint "
                             "(a loose object)")
        return int(self.model.jnt_qposadr[jnt])

    def _remap_masks(self) -> None:
        """Contact bitmasks under which world geoms never collide with each other.

        With original masks t, a below 2**16: world geoms get contype 0 and conaffinity ``a | t << 16``,
        moving geoms contype ``t | a << 16`` and conaffinity ``a``. A world–moving pair then collides iff
        ``t_m & a_w or a_m & t_w`` (as before), moving–moving pairs as before, world–world pairs never.
        """
        t, a = self._base_contype.astype(np.int64), self._base_conaffinity.astype(np.int64)
        if t.max(initial=0) >= 1 << 16 or a.max(initial=0) >= 1 << 16:
            return  # exotic masks: keep them, world-world contacts are then generated and ignored
        moving = self._kind != WORLD
        self.model.geom_contype[:] = np.where(moving, t | (a << 16), 0)
        self.model.geom_conaffinity[:] = np.where(moving, a, a | (t << 16))

    def set_margin(self, margin: float) -> None:
        """Change the world margin (m) of moving geoms, keeping the other rules."""
        moving = self._kind != WORLD
        self._margin = float(margin)
        self.model.geom_margin[:] = self._base_margin
        self.model.geom_margin[moving] = np.maximum(self._base_margin[moving], self._margin)
        self._update_thresholds()

    def _update_thresholds(self) -> None:
        """A contact between geoms i and j is invalid when its distance is below ``threshold[i, j]``."""
        world = self._kind == WORLD
        gripper = self._kind == GRIPPER
        any_world = world[:, None] | world[None, :]
        thr = np.where(any_world, self._margin, self.config.self_margin)
        thr = np.where(self._exact, np.minimum(thr, 0.0), thr)
        hand = gripper | (self._kind == HELD)
        ignore = (world[:, None] & world[None, :]) | (hand[:, None] & hand[None, :]) | self._allowed
        self._threshold = np.where(ignore, -np.inf, thr)

    def relax_pairs_at(self, q: np.ndarray) -> None:
        """Judge exactly (penetration only) the pairs within the margin, but not touching, at ``q``."""
        self._set(q)
        n = self.data.ncon
        if n == 0:
            return
        g1, g2 = self.data.contact.geom[:n, 0], self.data.contact.geom[:n, 1]
        dist = self.data.contact.dist[:n]
        near = (dist >= 0.0) & (dist < self._threshold[g1, g2])
        self._exact[g1[near], g2[near]] = True
        self._exact[g2[near], g1[near]] = True
        self._update_thresholds()

    # ----------------------------------------------------------------------------------------- queries
    def _set(self, q: np.ndarray) -> None:
        m, d = self.model, self.data
        d.qpos[self._arm_adr] = q
        mujoco.mj_kinematics(m, d)
        if self._attached is not None:
            world_T_tcp = np.eye(4)
            world_T_tcp[:3, :3] = d.site_xmat[self._tcp].reshape(3, 3)
            world_T_tcp[:3, 3] = d.site_xpos[self._tcp]
            world_T_held = world_T_tcp @ self._attached.tcp_T_body
            for adr, held_T_body in self._carried:
                T = world_T_held @ held_T_body
                d.qpos[adr:adr + 3] = T[:3, 3]
                mujoco.mju_mat2Quat(d.qpos[adr + 3:adr + 7], T[:3, :3].ravel())
            mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        self.n_checks += 1

    def _bad(self) -> np.ndarray:
        """Indices of the current contacts that make the configuration invalid."""
        n = self.data.ncon
        geoms = self.data.contact.geom[:n]
        return np.flatnonzero(self.data.contact.dist[:n] < self._threshold[geoms[:, 0], geoms[:, 1]])

    def valid(self, q: np.ndarray) -> bool:
        """Whether arm configuration ``q`` (7,) is collision-free under the configured rules."""
        self._set(q)
        return self.data.ncon == 0 or len(self._bad()) == 0

    def collisions(self, q: np.ndarray) -> list[Contact]:
        """The invalid contacts at ``q``, deepest first (empty when ``q`` is valid)."""
        self._set(q)
        if self.data.ncon == 0:
            return []
        m, con = self.model, self.data.contact
        found = []
        for i in self._bad():
            g1, g2 = con.geom[i]
            if self._kind[g1] == WORLD:  # name the moving part first: "hand <-> wall"
                g1, g2 = g2, g1
            found.append(Contact(m.body(m.geom_bodyid[g1]).name, m.body(m.geom_bodyid[g2]).name,
                                 float(con.dist[i])))
        return sorted(found, key=lambda c: c.dist)

    def explain(self, q: np.ndarray) -> str:
        """One line naming the deepest invalid contact at ``q``, or ``"no collision"``."""
        found = self.collisions(q)
        return str(found[0]) if found else "no collision"

    def first_invalid(self, path: np.ndarray, step: float) -> tuple[int, np.ndarray] | None:
        """Check the polyline ``path`` (M, 7) at joint steps of at most ``step`` rad (max-norm).

        Returns the index of the segment's start and the first invalid configuration, or None if all valid.
        """
        for i in range(len(path)):
            if i == 0:
                if not self.valid(path[0]):
                    return 0, path[0]
                continue
            a, b = path[i - 1], path[i]
            n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
            for k in range(1, n + 1):
                q = a + (b - a) * (k / n)
                if not self.valid(q):
                    return i - 1, q
        return None

    def world_T_tcp(self, q: np.ndarray) -> np.ndarray:
        """World pose (4x4) of the TCP at ``q`` in this scene (no collision query)."""
        m, d = self.model, self.data
        d.qpos[self._arm_adr] = q
        mujoco.mj_kinematics(m, d)
        T = np.eye(4)
        T[:3, :3] = d.site_xmat[self._tcp].reshape(3, 3)
        T[:3, 3] = d.site_xpos[self._tcp]
        return T


def _free_pose(qpos: np.ndarray, adr: int) -> np.ndarray:
    """World pose (4x4) of a free body from its joint's qpos (position, then quaternion w, x, y, z)."""
    T = np.eye(4)
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, qpos[adr + 3:adr + 7])
    T[:3, :3] = mat.reshape(3, 3)
    T[:3, 3] = qpos[adr:adr + 3]
    return T
