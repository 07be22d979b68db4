"""Triangle meshes of compiled MuJoCo geoms, for the browser view, clicks and the width check.

Geoms are taken from a compiled scene (so links, articulations and MuJoCo's mesh recentring are already
applied) and expressed in a chosen frame; colours come from the geom's material if it has one.

Example::

    parts = geom_meshes(model, data, ids, np.linalg.inv(world_T_object))   # [(trimesh, rgba)]
"""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh

VISUAL_GROUPS = (0, 1, 2)
"""Geom groups that are seen (group 3 holds invisible collision parts)."""


def _primitive(kind: int, size: np.ndarray) -> trimesh.Trimesh | None:
    g = mujoco.mjtGeom
    if kind == g.mjGEOM_BOX:
        return trimesh.creation.box(extents=2.0 * size[:3])
    if kind == g.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=32)
    if kind == g.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if kind == g.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(radius=size[0], height=2.0 * size[1], count=[16, 16])
    if kind == g.mjGEOM_ELLIPSOID:
        sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        sphere.apply_scale(size[:3])
        return sphere
    return None  # planes, heightfields: not part of objects or the hand


def geom_mesh(model: mujoco.MjModel, data: mujoco.MjData, geom: int, frame_T_world: np.ndarray
              ) -> trimesh.Trimesh | None:
    """Geom ``geom`` as a mesh in the frame ``frame_T_world`` maps world points into."""
    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_MESH:
        mid = model.geom_dataid[geom]
        v0, nv = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
        f0, nf = model.mesh_faceadr[mid], model.mesh_facenum[mid]
        mesh = trimesh.Trimesh(model.mesh_vert[v0:v0 + nv].copy(), model.mesh_face[f0:f0 + nf].copy(),
                               process=False)
    else:
        mesh = _primitive(int(model.geom_type[geom]), model.geom_size[geom])
        if mesh is None:
            return None
    T = np.eye(4)
    T[:3, :3] = data.geom_xmat[geom].reshape(3, 3)
    T[:3, 3] = data.geom_xpos[geom]
    mesh.apply_transform(frame_T_world @ T)
    return mesh


def geom_rgba(model: mujoco.MjModel, geom: int) -> tuple[float, float, float, float]:
    mat = model.geom_matid[geom]
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[geom]
    return tuple(float(c) for c in rgba)  # type: ignore[return-value]


def geom_meshes(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray, frame_T_world: np.ndarray
                ) -> list[tuple[trimesh.Trimesh, tuple[float, float, float, float]]]:
    """Meshes of ``geoms`` in one frame, merged per colour (fewer scene nodes in the browser)."""
    by_colour: dict[tuple[float, float, float, float], list[trimesh.Trimesh]] = {}
    for g in geoms:
        mesh = geom_mesh(model, data, int(g), frame_T_world)
        if mesh is not None:
            by_colour.setdefault(geom_rgba(model, int(g)), []).append(mesh)
    return [(trimesh.util.concatenate(ms), rgba) for rgba, ms in by_colour.items()]


def body_subtree_geoms(model: mujoco.MjModel, body: int, groups: tuple[int, ...] | None = None) -> np.ndarray:
    """Geoms of ``body`` and its descendants, optionally only those in ``groups``."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[body] = True
    for b in range(body + 1, model.nbody):
        inside[b] = inside[model.body_parentid[b]]
    mask = inside[model.geom_bodyid]
    if groups is not None:
        mask &= np.isin(model.geom_group, groups)
    return np.flatnonzero(mask)
