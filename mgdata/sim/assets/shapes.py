"""Exact analytic convex parts and smooth visual meshes for revolved and box-like shapes (instant, no coacd).

A revolved vessel (cup, bowl, jar) is described by its outer profile ``(r, z)`` from the bottom (z = 0) to
the rim, a wall thickness and a bottom thickness. Collision: one solid frustum for the bottom plus, for each
profile band, ``sectors`` wedge hulls of the wall (8 vertices each; MuJoCo takes the convex hull). The
polygonal inner wall lies ``r·(1 − cos(π/sectors))`` inside the true one, which is why particle fills leave
that clearance.
Visual: one watertight surface of revolution (trimesh).
"""

from __future__ import annotations

import numpy as np
import trimesh

from mgdata.sim.assets.model import Geom, Mesh

VISUAL_SECTIONS = 40
"""Angular resolution of visual surfaces of revolution (render cost grows with it)."""


def revolve(outline: np.ndarray, sections: int = VISUAL_SECTIONS) -> Mesh:
    """Surface of revolution about +Z of an (r, z) outline that starts and ends on the axis (watertight)."""
    mesh = trimesh.creation.revolve(np.asarray(outline, dtype=np.float64), sections=sections)
    return Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int32))


def _ring(r: float, z: float, a0: float, a1: float) -> np.ndarray:
    return np.array([[r * np.cos(a0), r * np.sin(a0), z], [r * np.cos(a1), r * np.sin(a1), z]])


def frustum_hull(r0: float, z0: float, r1: float, z1: float, sectors: int) -> Mesh:
    """A solid frustum between heights z0 and z1 as one convex hull (polygon with ``sectors`` sides)."""
    a = np.linspace(0.0, 2.0 * np.pi, sectors, endpoint=False)
    bottom = np.stack([r0 * np.cos(a), r0 * np.sin(a), np.full_like(a, z0)], axis=1)
    top = np.stack([r1 * np.cos(a), r1 * np.sin(a), np.full_like(a, z1)], axis=1)
    return Mesh(np.concatenate([bottom, top]))


def vessel_inner(outer: np.ndarray, wall: float, bottom: float) -> np.ndarray:
    """The inner profile matching ``outer`` (rows with z ≥ bottom, radii reduced by ``wall``)."""
    outer = np.asarray(outer, dtype=np.float64)
    zs = np.concatenate([[bottom], outer[outer[:, 1] > bottom, 1]])
    rs = np.interp(zs, outer[:, 1], outer[:, 0]) - wall
    return np.stack([rs, zs], axis=1)


def vessel_geoms(outer: np.ndarray, wall: float, bottom: float, sectors: int, prefix: str = "") -> tuple[
    tuple[Geom, ...], Mesh
]:
    """Collision hulls and the visual mesh of an open vessel.

    Args:
        outer: (k, 2) outer profile (r, z), z increasing from 0 to the rim height.
        wall: wall thickness (m), measured radially.
        bottom: thickness of the solid bottom (m).
        sectors: wedges around the circumference.
        prefix: prefix of the geom names (``wall_00_03`` is band 0, sector 3).
    """
    outer = np.asarray(outer, dtype=np.float64)
    inner = vessel_inner(outer, wall, bottom)
    r_out = lambda z: float(np.interp(z, outer[:, 1], outer[:, 0]))  # noqa: E731
    geoms: list[Geom] = [
        Geom(f"{prefix}bottom", "mesh", mesh=frustum_hull(r_out(0.0), 0.0, r_out(bottom), bottom, sectors),
             role="collision")
    ]
    edges = np.linspace(0.0, 2.0 * np.pi, sectors + 1)
    for band in range(len(inner) - 1):
        z0, z1 = inner[band, 1], inner[band + 1, 1]
        ri0, ri1 = inner[band, 0], inner[band + 1, 0]
        ro0, ro1 = r_out(z0), r_out(z1)
        for s in range(sectors):
            a0, a1 = edges[s], edges[s + 1]
            verts = np.concatenate([_ring(ro0, z0, a0, a1), _ring(ro1, z1, a0, a1),
                                    _ring(ri0, z0, a0, a1), _ring(ri1, z1, a0, a1)])
            geoms.append(Geom(f"{prefix}wall_{band:02d}_{s:02d}", "mesh", mesh=Mesh(verts), role="collision"))
    outline = np.concatenate([[[0.0, 0.0]], outer, inner[::-1], [[0.0, bottom]]])
    return tuple(geoms), revolve(outline)


def box_shell_geoms(half_x: float, half_y: float, height: float, wall: float, bottom: float,
                    prefix: str = "") -> tuple[Geom, ...]:
    """An open box (tub, tray, drawer): a bottom slab and four walls, all visible colliding boxes."""
    hz = (height - bottom) / 2.0
    zc = bottom + hz
    return (
        Geom(f"{prefix}bottom", "box", (half_x, half_y, bottom / 2.0), pos=(0.0, 0.0, bottom / 2.0)),
        Geom(f"{prefix}wall_px", "box", (wall / 2.0, half_y, hz), pos=(half_x - wall / 2.0, 0.0, zc)),
        Geom(f"{prefix}wall_nx", "box", (wall / 2.0, half_y, hz), pos=(-half_x + wall / 2.0, 0.0, zc)),
        Geom(f"{prefix}wall_py", "box", (half_x - wall, wall / 2.0, hz), pos=(0.0, half_y - wall / 2.0, zc)),
        Geom(f"{prefix}wall_ny", "box", (half_x - wall, wall / 2.0, hz), pos=(0.0, -half_y + wall / 2.0, zc)),
    )


def arc_capsules(center: tuple[float, float], radius: float, thickness: float, a0: float, a1: float,
                 pieces: int, prefix: str) -> tuple[Geom, ...]:
    """Capsules along an arc in the x–z plane (a mug handle): centre (x, z), angles a0..a1 (rad)."""
    angles = np.linspace(a0, a1, pieces + 1)
    geoms = []
    for i in range(pieces):
        p0 = np.array([center[0] + radius * np.cos(angles[i]), 0.0, center[1] + radius * np.sin(angles[i])])
        p1 = np.array([center[0] + radius * np.cos(angles[i + 1]), 0.0,
                       center[1] + radius * np.sin(angles[i + 1])])
        mid, d = (p0 + p1) / 2.0, p1 - p0
        half = float(np.linalg.norm(d)) / 2.0
        geoms.append(Geom(f"{prefix}{i:02d}", "capsule", (thickness, half), pos=tuple(mid),
                          quat=quat_z_to(d)))
    return tuple(geoms)


def quat_z_to(direction: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) rotating +Z onto ``direction``."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, d))
    if c < -1.0 + 1e-12:
        return (0.0, 1.0, 0.0, 0.0)
    axis = np.cross(z, d)
    q = np.array([1.0 + c, *axis])
    q /= np.linalg.norm(q)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
