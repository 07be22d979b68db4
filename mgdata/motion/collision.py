"""Collision checking of arm configurations in a private copy of the scene.

The checker owns a copy of the scene's ``MjModel`` and its own ``MjData``: the live simulation is never
touched. :meth:`CollisionChecker.sync` copies the world state (object poses, finger opening) in; each check
then writes the seven arm joints (and the pose of a held object, which moves rigidly with the TCP), runs
``mj_kinematics`` + ``mj_collision`` and judges every contact that involves a *moving* geom — a robot geom or
a held-object geom:

* moving ↔ world: invalid when closer than the query's margin (the planning margin while planning, 0 on the
  exact recheck);
* robot ↔ robot: invalid when closer than ``self_margin``; contacts inside the gripper (palm and fingers
  touching each other) are ignored;
* pairs named in :class:`~mgdata.motion.types.AllowedContacts` are ignored;
* pairs already within the margin at the start or goal of a query are judged exactly (penetration only), so a
  motion may leave a configuration that sits close to a surface without granting it any real contact.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.motion.config import CheckConfig
from mgdata.motion.types import AllowedContacts, Attachment
from mgdata.sim.robot import HAND_BODY, TCP_SITE, arm_qpos_adr, robot_body_ids, robot_geom_ids

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
        self.data = mujoco.MjData(self.model)
        self._arm_adr = arm_qpos_adr(model)
        self._tcp = model.site(TCP_SITE).id
        self._base_margin = model.geom_margin.copy()
        n = model.ngeom
        self._robot_geoms = robot_geom_ids(model)
        self._kind0 = np.full(n, WORLD, dtype=np.int8)
        self._kind0[self._robot_geoms] = ROBOT
        hand_bodies = self._subtree(model.body(HAND_BODY).id)
        self._kind0[self._robot_geoms[np.isin(model.geom_bodyid[self._robot_geoms], hand_bodies)]] = GRIPPER
        self._robot_bodies = robot_body_ids(model)
        self._kind = self._kind0.copy()
        self._allowed = np.zeros((n, n), dtype=bool)
        self._exact = np.zeros((n, n), dtype=bool)
        self._margin = 0.0
        self._attached: Attachment | None = None
        self._held_adr = -1
        self.n_checks = 0

    # ----------------------------------------------------------------------------------------- set-up
    def _subtree(self, body: int) -> np.ndarray:
        """Ids of ``body`` and all its descendants."""
        m = self.model
        ids = [body]
        for b in range(body + 1, m.nbody):
            parent = m.body_parentid[b]
            if parent in ids:
                ids.append(b)
        return np.array(ids, dtype=np.int32)

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
        self.data.qpos[:] = data.qpos
        self.data.mocap_pos[:] = data.mocap_pos
        self.data.mocap_quat[:] = data.mocap_quat

    def configure(self, allowed: AllowedContacts, attached: Attachment | None, margin: float) -> None:
        """Set the rules of the next queries: allowed pairs, held object, and the world margin (m).

        Also forgets the pairs relaxed by :meth:`relax_pairs_at`.
        """
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
        self._held_adr = -1
        if attached is not None:
            body = self._body_id(attached.body, "Attachment")
            jnt = self.model.body_jntadr[body]
            if (self.model.body_parentid[body] != 0 or jnt < 0
                    or self.model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE):
                raise SceneError(f"Attachment body {attached.body!r} must be a child of the world with a "
                                 "free joint (a loose object)")
            if body in self._robot_bodies:
                raise SceneError(f"Attachment body {attached.body!r} is part of the robot")
            self._held_adr = int(self.model.jnt_qposadr[jnt])
            self._kind[self._subtree_geoms(attached.body, "Attachment")] = HELD
        self.set_margin(margin)

    def set_margin(self, margin: float) -> None:
        """Change the world margin (m) of moving geoms, keeping the other rules."""
        moving = np.flatnonzero(self._kind != WORLD)
        self._margin = float(margin)
        self.model.geom_margin[:] = self._base_margin
        self.model.geom_margin[moving] = np.maximum(self._base_margin[moving], self._margin)

    def relax_pairs_at(self, q: np.ndarray) -> None:
        """Judge exactly (penetration only) the pairs within the margin, but not touching, at ``q``."""
        self._set(q)
        for g1, g2, dist in self._contacts():
            if dist >= 0.0 and self._judge(g1, g2, dist):
                self._exact[g1, g2] = self._exact[g2, g1] = True

    # ----------------------------------------------------------------------------------------- queries
    def _set(self, q: np.ndarray) -> None:
        m, d = self.model, self.data
        d.qpos[self._arm_adr] = q
        mujoco.mj_kinematics(m, d)
        if self._attached is not None:
            world_T_tcp = np.eye(4)
            world_T_tcp[:3, :3] = d.site_xmat[self._tcp].reshape(3, 3)
            world_T_tcp[:3, 3] = d.site_xpos[self._tcp]
            T = world_T_tcp @ self._attached.tcp_T_body
            adr = self._held_adr
            d.qpos[adr:adr + 3] = T[:3, 3]
            mujoco.mju_mat2Quat(d.qpos[adr + 3:adr + 7], T[:3, :3].ravel())
            mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        self.n_checks += 1

    def _contacts(self) -> list[tuple[int, int, float]]:
        n = self.data.ncon
        if n == 0:
            return []
        geoms = self.data.contact.geom[:n]
        dist = self.data.contact.dist[:n]
        return [(int(a), int(b), float(x)) for (a, b), x in zip(geoms, dist, strict=True)]

    def _judge(self, g1: int, g2: int, dist: float) -> bool:
        """True when the contact makes the configuration invalid (ignoring the exact-pair override)."""
        k1, k2 = self._kind[g1], self._kind[g2]
        if (k1 == WORLD and k2 == WORLD) or self._allowed[g1, g2]:
            return False
        if k1 == WORLD or k2 == WORLD:
            return dist < self._margin
        if k1 == GRIPPER and k2 == GRIPPER:
            return False
        return dist < self.config.self_margin

    def _bad_mask(self) -> np.ndarray:
        n = self.data.ncon
        geoms = self.data.contact.geom[:n]
        g1, g2 = geoms[:, 0], geoms[:, 1]
        dist = self.data.contact.dist[:n]
        k1, k2 = self._kind[g1], self._kind[g2]
        world = (k1 == WORLD) | (k2 == WORLD)
        threshold = np.where(world, self._margin, self.config.self_margin)
        threshold = np.where(self._exact[g1, g2], 0.0, threshold)
        bad = (dist < threshold) & ~self._allowed[g1, g2]
        bad &= ~((k1 == WORLD) & (k2 == WORLD))
        bad &= ~((k1 == GRIPPER) & (k2 == GRIPPER))
        return bad

    def valid(self, q: np.ndarray) -> bool:
        """Whether arm configuration ``q`` (7,) is collision-free under the configured rules."""
        self._set(q)
        return self.data.ncon == 0 or not self._bad_mask().any()

    def collisions(self, q: np.ndarray) -> list[Contact]:
        """The invalid contacts at ``q``, deepest first (empty when ``q`` is valid)."""
        self._set(q)
        if self.data.ncon == 0:
            return []
        bad = np.flatnonzero(self._bad_mask())
        m, con = self.model, self.data.contact
        found = []
        for i in bad:
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
