"""Geometric queries over a set of geoms, exact and cheap enough to run every control step.

``LowestPoint`` is the exact support point of a geom set in −Z: analytic for primitives, the minimum over
vertices for meshes (collision meshes are convex hulls, so their vertices are exact).
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
