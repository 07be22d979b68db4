"""ObjectModel: a procedurally generated, redistributable object as plain data that adds itself to an MjSpec.

Every model has a canonical local frame: **origin at the bottom centre of the object's bounding box, +Z up**,
+X its "front" (the side a handle, hinge-free edge or drawer faces; see each kind's docstring). A model is a
root part (``geoms``) plus optional child ``links`` on one joint each (a jar lid on a hinge, a drawer on a
slide). Geoms come in three roles: ``collision`` (group 3, invisible, exact convex parts), ``visual``
(group 2, no contacts, no mass) and ``both`` (group 0, a primitive that is seen and collides). Masses are
explicit: each colliding geom carries its share of its part's mass, proportional to volume.

When added to a scene under instance name ``jar``, every geom, joint, site, mesh and child body is named
``jar/<local name>`` (``jar/lid``, ``jar/lid_hinge``); the instance's root body (created by the scene builder)
is named ``jar``. A visual mesh may carry a :class:`Texture` (imported objects): its geom gets a material and
a 2D texture of the same name (``jar/visual``).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

_KIND = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID,
    "mesh": mujoco.mjtGeom.mjGEOM_MESH,
}
_GROUP = {"collision": 3, "visual": 2, "both": 0}
CONDIM = 4
"""Contact dimensionality of object geoms: sliding plus torsional friction, so two-finger grasps resist
spinning about the closing axis and do not chatter."""
TORSIONAL_FRICTION = 0.005
ROLLING_FRICTION = 0.0001


@dataclass(frozen=True, eq=False)
class Mesh:
    """Vertices (n, 3) and faces (m, 3); empty ``faces`` means the convex hull of the vertices (collision).

    ``texcoords`` (n, 2), one per vertex, in the OBJ convention (u right, v up from the image's bottom row),
    for a visual mesh that carries a :class:`Texture`.
    """

    verts: np.ndarray
    faces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int32))
    texcoords: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Texture:
    """An RGB image (h, w, 3) uint8, top row first, wrapped onto a textured mesh by its ``texcoords``."""

    rgb: np.ndarray


@dataclass(frozen=True, eq=False)
class Geom:
    """One geom in a part's frame. ``size`` follows MuJoCo's convention for the primitive ``kind``."""

    name: str
    kind: str
    size: tuple[float, ...] = ()
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    mesh: Mesh | None = None
    role: str = "both"
    rgba: tuple[float, float, float, float] | None = None
    mass: float = 0.0
    texture: Texture | None = None

    @property
    def collides(self) -> bool:
        return self.role != "visual"

    def volume(self) -> float:
        """Volume (m³) of the geom's collision shape."""
        s = self.size
        if self.kind == "box":
            return 8.0 * s[0] * s[1] * s[2]
        if self.kind == "cylinder":
            return np.pi * s[0] ** 2 * 2.0 * s[1]
        if self.kind == "sphere":
            return 4.0 / 3.0 * np.pi * s[0] ** 3
        if self.kind == "capsule":
            return np.pi * s[0] ** 2 * 2.0 * s[1] + 4.0 / 3.0 * np.pi * s[0] ** 3
        if self.kind == "ellipsoid":
            return 4.0 / 3.0 * np.pi * s[0] * s[1] * s[2]
        assert self.mesh is not None
        return float(ConvexHull(self.mesh.verts).volume)


@dataclass(frozen=True)
class Joint:
    """The joint of a child link, in the link's frame; ``range`` in rad (hinge) or m (slide)."""

    name: str
    kind: str
    axis: tuple[float, float, float]
    range: tuple[float, float]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    damping: float = 0.0
    armature: float = 0.0
    frictionloss: float = 0.0


@dataclass(frozen=True, eq=False)
class Link:
    """A child body (``pos``/``quat`` in the root frame) moving on one joint: a lid, a drawer."""

    name: str
    joint: Joint
    geoms: tuple[Geom, ...]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Articulation:
    """The model's one articulation: joint ``joint`` (local name) at ``closed`` … ``open`` (joint units).

    ``fraction(q)`` maps a joint value to 0 (closed) … 1 (fully open), clipped.
    """

    joint: str
    kind: str
    closed: float
    open: float

    def value(self, fraction: float) -> float:
        return self.closed + fraction * (self.open - self.closed)

    def fraction(self, q: float) -> float:
        f = (q - self.closed) / (self.open - self.closed)
        return min(max(f, 0.0), 1.0)


@dataclass(frozen=True)
class Cavity:
    """The inside of a container in the local frame: a frustum (``shape="round"``: radii at ``floor_z`` and
    ``rim_z``) or a box (``shape="box"``: half extents ``half_x``, ``half_y``). Used for liquid fill and
    ``spilled``.
    """

    shape: str
    floor_z: float
    rim_z: float
    radius_floor: float = 0.0
    radius_rim: float = 0.0
    half_x: float = 0.0
    half_y: float = 0.0

    def contains(self, points: np.ndarray, *, margin: float = 0.0, headroom: float = 0.0) -> np.ndarray:
        """Which local-frame points (n, 3) lie inside (``margin`` sideways, ``headroom`` above the rim)."""
        z = points[:, 2]
        inside_z = (z >= self.floor_z - margin) & (z <= self.rim_z + headroom)
        if self.shape == "round":
            t = np.clip((z - self.floor_z) / (self.rim_z - self.floor_z), 0.0, 1.0)
            r = self.radius_floor + t * (self.radius_rim - self.radius_floor)
            return inside_z & (np.hypot(points[:, 0], points[:, 1]) <= r + margin)
        return inside_z & (np.abs(points[:, 0]) <= self.half_x + margin) & (
            np.abs(points[:, 1]) <= self.half_y + margin
        )


@dataclass(frozen=True, eq=False)
class Particles:
    """A particle set instead of a rigid body (see ``mgdata.sim.particles``).

    ``kind="liquid"``: ``count`` free spheres of ``radius`` and ``mass`` each, poured into the cavity of the
    container the placement point lies in. ``kind="dust"``: ``count`` flat visual discs at ``layout``
    (count, 2) xy offsets around the placement point, removed when a sponge wipes over them.
    """

    kind: str
    count: int
    radius: float
    mass: float = 0.0
    layout: np.ndarray | None = None


def model_seed(name: str) -> int:
    """The seed of a model: the first 8 bytes of SHA-256 of its name (stable across runs and machines)."""
    return int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "little")


def with_masses(geoms: tuple[Geom, ...], total: float) -> tuple[Geom, ...]:
    """Spread ``total`` kg over the colliding geoms in proportion to their volumes (visual geoms get 0)."""
    vols = np.array([g.volume() if g.collides else 0.0 for g in geoms])
    share = vols / vols.sum()
    return tuple(replace(g, mass=float(total * s)) for g, s in zip(geoms, share, strict=True))


@dataclass(frozen=True, eq=False)
class ObjectModel:
    """A library object. See the module docstring for the frame and naming conventions.

    Attributes:
        name: ``category/model``, e.g. ``"jar/hinged_03"``.
        category: ``"jar"``.
        seed: the seed its parameters were drawn from.
        params: the drawn parameters (m, kg, rad), for provenance.
        size: bounding-box extents (x, y, z) in m, with the articulation closed.
        mass: total mass (kg), links included.
        friction: sliding friction coefficient of its colliding geoms.
        rgba: main colour.
        geometry: facts other layers need (e.g. a jar's ``outer_radius``, ``hinge_pos``); documented per kind.
        geoms: the root part.
        links: child bodies on joints.
        articulation: the joint that opens/closes it, if any.
        cavity: the inside of a container, if it is one.
        fixed: welded to the world (a cabinet) instead of free.
        particles: set for particle models (liquid, dust); they have no ``geoms``.
    """

    name: str
    category: str
    seed: int
    params: Mapping[str, float]
    size: tuple[float, float, float]
    mass: float
    friction: float
    rgba: tuple[float, float, float, float]
    geometry: Mapping[str, Any]
    geoms: tuple[Geom, ...]
    links: tuple[Link, ...] = ()
    articulation: Articulation | None = None
    cavity: Cavity | None = None
    fixed: bool = False
    particles: Particles | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))
        object.__setattr__(self, "geometry", MappingProxyType(dict(self.geometry)))

    @property
    def model(self) -> str:
        """The part of ``name`` after the category."""
        return self.name.split("/", 1)[1]

    def add_to(self, spec: mujoco.MjSpec, body: mujoco.MjsBody, prefix: str) -> None:
        """Add the geoms, links, joints and meshes to ``body`` (the instance's root), names prefixed."""
        for g in self.geoms:
            self._add_geom(spec, body, g, prefix)
        for link in self.links:
            child = body.add_body(name=f"{prefix}{link.name}", pos=list(link.pos), quat=list(link.quat))
            j = link.joint
            child.add_joint(
                name=f"{prefix}{j.name}",
                type=mujoco.mjtJoint.mjJNT_HINGE if j.kind == "hinge" else mujoco.mjtJoint.mjJNT_SLIDE,
                axis=list(j.axis),
                pos=list(j.pos),
                range=list(j.range),
                limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                damping=j.damping,
                armature=j.armature,
                frictionloss=j.frictionloss,
            )
            for g in link.geoms:
                self._add_geom(spec, child, g, prefix)

    def _add_geom(self, spec: mujoco.MjSpec, body: mujoco.MjsBody, g: Geom, prefix: str) -> None:
        name = f"{prefix}{g.name}"
        kwargs: dict[str, Any] = {
            "name": name,
            "type": _KIND[g.kind],
            "pos": list(g.pos),
            "quat": list(g.quat),
            "group": _GROUP[g.role],
            "rgba": list(g.rgba or self.rgba),
            "mass": g.mass if g.collides else 0.0,
        }
        if g.kind == "mesh":
            assert g.mesh is not None
            mesh = spec.add_mesh(name=name)
            mesh.uservert = g.mesh.verts.ravel().tolist()
            if len(g.mesh.faces):
                mesh.userface = g.mesh.faces.ravel().tolist()
            if g.mesh.texcoords is not None:  # MuJoCo's v runs down the image from its top row (as its OBJ
                uv = np.asarray(g.mesh.texcoords, dtype=np.float64)  # loader does: v -> 1 - v)
                mesh.usertexcoord = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).ravel().tolist()
            kwargs["meshname"] = name
        else:
            kwargs["size"] = [*g.size, 0.0, 0.0][:3]
        if g.texture is not None:
            kwargs["material"] = _add_texture(spec, name, g.texture)
            kwargs["rgba"] = [1.0, 1.0, 1.0, 1.0]  # the image's own colours (a tint still multiplies them)
        if g.collides:
            kwargs["friction"] = [self.friction, TORSIONAL_FRICTION, ROLLING_FRICTION]
            kwargs["condim"] = CONDIM
        else:
            kwargs["contype"] = 0
            kwargs["conaffinity"] = 0
        body.add_geom(**kwargs)


def _add_texture(spec: mujoco.MjSpec, name: str, texture: Texture) -> str:
    """Add ``texture`` as a 2D texture and a material using it, both called ``name``; returns the name."""
    rgb = np.ascontiguousarray(texture.rgb, dtype=np.uint8)
    tex = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=rgb.shape[1],
                           height=rgb.shape[0], nchannel=3)
    tex.data = rgb.tobytes()
    material = spec.add_material(name=name, reflectance=0.0, specular=0.2)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
    return name
