"""Geometric queries over a set of geoms, exact and cheap enough to run every control step.

``LowestPoint`` is the exact support point of a geom set in −Z: analytic for primitives, the minimum over
vertices for meshes (collision meshes are convex hulls, so their vertices are exact). ``FlatTop`` is the top
face of a fixed support (table top, floor); ``GeomGaps`` the exact distances between two geom sets that are
within a small range (the contact tolerance of ``on``, ``touching`` and ``held``); ``box_grid`` and
``box_corners`` sample a bounding box (``in_region``).
"""

from __future__ import annotations

import mujoco
import numpy as np

_G = mujoco.mjtGeom


class LowestPoint:
    """Height (m) of the lowest point of the geoms ``geom_ids`` in the current state."""

    def __init__(self, model: mujoco.MjModel, geom_ids: np.ndarray) -> None:
        ids = np.asarray(geom_ids, dtype=np.int32)
        types = model.geom_type[ids]
        self._box = ids[types == _G.mjGEOM_BOX]
        self._sphere = ids[types == _G.mjGEOM_SPHERE]
        self._capsule = ids[types == _G.mjGEOM_CAPSULE]
        self._cylinder = ids[types == _G.mjGEOM_CYLINDER]
        self._ellipsoid = ids[types == _G.mjGEOM_ELLIPSOID]
        meshes = ids[types == _G.mjGEOM_MESH]
        verts, owners = [], []
        for g in meshes:
            mesh = model.geom_dataid[g]
            adr, n = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            verts.append(model.mesh_vert[adr : adr + n])
            owners.append(np.full(n, g, dtype=np.int32))
        self._verts = np.concatenate(verts) if verts else np.zeros((0, 3))
        self._vert_geom = np.concatenate(owners) if owners else np.zeros(0, dtype=np.int32)
        unsupported = set(types.tolist()) - {_G.mjGEOM_BOX, _G.mjGEOM_SPHERE, _G.mjGEOM_CAPSULE,
                                             _G.mjGEOM_CYLINDER, _G.mjGEOM_ELLIPSOID, _G.mjGEOM_MESH}
        if unsupported:
            raise ValueError(f"LowestPoint: unsupported geom types {sorted(unsupported)}")
        self._size = model.geom_size
        self._ids = ids
        self._rbound = np.where(types == _G.mjGEOM_PLANE, np.inf, model.geom_rbound[ids])

    def lower_bound(self, data: mujoco.MjData) -> float:
        """A cheap bound ≤ the lowest point (each geom's bounding sphere): a test against a height far below
        the geoms needs no exact computation."""
        return float((data.geom_xpos[self._ids, 2] - self._rbound).min())

    def below(self, data: mujoco.MjData, z: float) -> bool:
        """Is the lowest point below ``z``? (exact; the bound answers most calls)"""
        return self.lower_bound(data) < z and self(data) < z

    def __call__(self, data: mujoco.MjData) -> float:
        low = np.inf
        xz, xm, size = data.geom_xpos[:, 2], data.geom_xmat, self._size
        if len(self._verts):
            g = self._vert_geom
            low = min(low, float((xz[g] + np.einsum("ij,ij->i", xm[g, 6:9], self._verts)).min()))
        if len(self._box):
            g = self._box
            low = min(low, float((xz[g] - np.abs(xm[g, 6:9] * size[g]).sum(axis=1)).min()))
        if len(self._sphere):
            low = min(low, float((xz[self._sphere] - size[self._sphere, 0]).min()))
        if len(self._capsule):
            g = self._capsule
            low = min(low, float((xz[g] - np.abs(xm[g, 8]) * size[g, 1] - size[g, 0]).min()))
        if len(self._cylinder):
            g = self._cylinder
            c = np.abs(xm[g, 8])
            side = np.sqrt(np.maximum(0.0, 1.0 - c * c))
            low = min(low, float((xz[g] - c * size[g, 1] - side * size[g, 0]).min()))
        if len(self._ellipsoid):
            g = self._ellipsoid
            low = min(low, float((xz[g] - np.sqrt(((xm[g, 6:9] * size[g]) ** 2).sum(axis=1))).min()))
        return low


class FlatTop:
    """The top face of a world-fixed, axis-aligned box geom (the table top) or a plane (the floor).

    Attributes:
        z: height of the face (m).
        lo, hi: its horizontal extent (x, y) in m; a plane is unbounded (as MuJoCo collides it).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> None:
        kind, size = model.geom_type[geom], model.geom_size[geom]
        if model.body_weldid[model.geom_bodyid[geom]] != 0 or not np.allclose(data.geom_xmat[geom],
                                                                              np.eye(3).ravel()):
            raise ValueError(f"FlatTop: geom {geom} is not a world-fixed, axis-aligned face")
        centre = data.geom_xpos[geom]
        if kind == _G.mjGEOM_BOX:
            self.z = float(centre[2] + size[2])
            half = size[:2]
        elif kind == _G.mjGEOM_PLANE:
            self.z = float(centre[2])
            half = np.array([np.inf, np.inf])
        else:
            raise ValueError(f"FlatTop: geom {geom} is neither a box nor a plane")
        self.lo, self.hi = centre[:2] - half, centre[:2] + half

    def overlaps(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Does the horizontal rectangle ``[lo, hi]`` (x, y) overlap the face?"""
        return bool(np.all(lo[:2] <= self.hi) and np.all(hi[:2] >= self.lo))


class GeomGaps:
    """Signed distances (m) between two geom sets, computed exactly (``mujoco.mj_geomDistance``) for the
    pairs whose bounding spheres come within ``distmax``; every other pair is farther than ``distmax``.

    Planes have no bounding sphere (MuJoCo's ``geom_rbound`` is 0) and are always measured.
    """

    def __init__(self, model: mujoco.MjModel, a: np.ndarray, b: np.ndarray, distmax: float) -> None:
        ga, gb = np.meshgrid(np.asarray(a, dtype=np.int32), np.asarray(b, dtype=np.int32), indexing="ij")
        keep = ga != gb
        self._a, self._b = ga[keep], gb[keep]
        r = np.where(model.geom_type == _G.mjGEOM_PLANE, np.inf, model.geom_rbound)
        self._reach = r[self._a] + r[self._b] + distmax
        self._model, self.distmax = model, float(distmax)
        self._fromto = np.zeros(6)

    def near(self, data: mujoco.MjData) -> list[tuple[float, np.ndarray]]:
        """``(distance, direction)`` of every pair closer than ``distmax``; ``direction`` is the unit vector
        from the set-``b`` geom's nearest point to the set-``a`` geom's (zero when they touch or overlap)."""
        xa, xb = data.geom_xpos[self._a], data.geom_xpos[self._b]
        candidates = np.flatnonzero(np.einsum("ij,ij->i", xa - xb, xa - xb) <= self._reach**2)
        out = []
        for i in candidates.tolist():
            dist = mujoco.mj_geomDistance(self._model, data, int(self._a[i]), int(self._b[i]), self.distmax,
                                          self._fromto)
            if dist < self.distmax:
                step = self._fromto[:3] - self._fromto[3:]
                length = float(np.linalg.norm(step))
                out.append((dist, step / length if dist > 0.0 and length > 0.0 else np.zeros(3)))
        return out

    def min(self, data: mujoco.MjData) -> float:
        """The smallest distance, or ``distmax`` if no pair is closer."""
        return min((d for d, _ in self.near(data)), default=self.distmax)


def box_grid(lo: np.ndarray, hi: np.ndarray, n: int) -> np.ndarray:
    """Centres of the ``n``³ equal cells of the box ``[lo, hi]``, (n³, 3): a fixed, deterministic sample of
    its volume (the midpoint rule)."""
    t = (np.arange(n) + 0.5) / n
    axes = [lo[k] + t * (hi[k] - lo[k]) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The 8 corners of the box ``[lo, hi]``, (8, 3)."""
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
