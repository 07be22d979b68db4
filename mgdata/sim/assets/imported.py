"""Objects from mesh files: the visual is the mesh itself (with its UV texture, if it has one), the collision
is its cached coacd decomposition.

Frame: the mesh is scaled, then translated so the origin is the bottom centre of its bounding box; +Z is the
file's +Z. ``geometry``: ``source`` (the file), ``hulls`` (number of convex parts), ``textured``.

What a file must be (each a one-line :class:`~mgdata.errors.AssetError`):

* readable by trimesh (OBJ with its MTL and image, GLB/glTF with an embedded image, STL, PLY …), with faces;
* **closed**: once coincident vertices are merged, every edge belongs to exactly two faces. coacd splits the
  *inside* of a surface into convex parts, and an open or non-manifold surface has no inside (coacd then
  returns hulls of fragments or of the whole bounding region); close holes first (e.g. Blender's 3D-Print
  toolbox, ``trimesh.repair.fill_holes``);
* of a plausible size: its largest extent after ``scale`` within :data:`EXTENT_RANGE` (a tabletop object),
  its mass within :data:`MASS_RANGE` and its density (mass over the closed mesh's volume) within
  :data:`DENSITY_RANGE` (a mass meant for another scale, or a scale meant for other units, shows there);
* textured, when it names a texture: a material whose image is missing is an error, never a grey object.

Example::

    model = mesh_model("toy/duck", Path("duck.obj"), mass=0.1)
    register(model)
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mgdata.errors import AssetError
from mgdata.sim.assets.model import Geom, Mesh, ObjectModel, Texture, model_seed, with_masses
from mgdata.sim.collision import DecompositionSettings, convex_decomposition

EXTENT_RANGE = (0.01, 0.5)
"""m: the largest bounding-box extent of an imported object, after scaling (a tabletop object the hand
can meet; a file in millimetres imported at scale 1 is 1000 times too big)."""
MASS_RANGE = (0.005, 3.0)
"""kg: up to the Panda's 3 kg payload."""
DENSITY_RANGE = (10.0, 25000.0)
"""kg/m³ of the closed mesh: from foam (~20) to past lead (11,300)."""
FRICTION_RANGE = (0.05, 2.0)
"""Sliding friction coefficient."""
MAX_TEXTURE_SIDE = 1024
"""px: a larger texture is scaled down to this (every dataset stores the compiled scene, image included;
a 256-px camera cannot show more)."""
NAME = re.compile(r"^[a-z0-9][a-z0-9_-]*$")
"""What a category and a model name may be (lowercase, digits, ``_``, ``-``)."""


@dataclass(frozen=True, eq=False)
class SurfaceMesh:
    """A mesh file as read: vertices (n, 3) and faces (m, 3) in the file's units, per-vertex ``texcoords``
    (n, 2, OBJ convention) and the texture ``image`` (h, w, 3 uint8, top row first), both or neither."""

    verts: np.ndarray
    faces: np.ndarray
    texcoords: np.ndarray | None = None
    image: np.ndarray | None = None


def check_name(name: str) -> None:
    """Raise :class:`AssetError` unless ``name`` is ``category/model`` of :data:`NAME` parts."""
    parts = name.split("/")
    if len(parts) != 2 or not all(NAME.match(p) for p in parts):
        raise AssetError(f"model name {name!r} must be 'category/model', each part lowercase letters, "
                         "digits, '_' or '-' (e.g. 'mug/scanned_00')")


def read_mesh(path: Path, texture: Path | None = None) -> SurfaceMesh:
    """Read ``path`` (any format trimesh reads), with ``texture`` as its image instead of the file's own.

    Raises:
        AssetError: a missing or unreadable file, no faces, a material naming a missing image, an image
            that is not readable, or ``texture`` given for a mesh without texture coordinates.
    """
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise AssetError(f"mesh file {path} does not exist")
    try:
        loaded = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise AssetError(f"cannot read mesh {path}: {exc}") from exc
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(faces) == 0:
        raise AssetError(f"mesh {path} has no faces")
    verts = np.asarray(loaded.vertices, dtype=np.float64)
    uv = getattr(loaded.visual, "uv", None)
    uv = None if uv is None or len(uv) != len(verts) else np.asarray(uv, dtype=np.float64)
    if texture is not None:
        if uv is None:
            raise AssetError(f"mesh {path} has no texture coordinates, so texture {texture} cannot be "
                             "wrapped onto it (export it with UVs)")
        return SurfaceMesh(verts, faces, uv, _read_image(Path(texture)))
    image = _material_image(loaded)
    missing = _missing_textures(path)
    if missing:
        raise AssetError(f"mesh {path}: its material names texture {missing[0]}, which does not exist "
                         "(copy it beside the mesh, or give the image with --texture)")
    if uv is None or image is None:
        return SurfaceMesh(verts, faces)
    return SurfaceMesh(verts, faces, uv, _rgb(image))


def _material_image(loaded: object) -> object | None:
    material = getattr(getattr(loaded, "visual", None), "material", None)
    if material is None:
        return None
    image = getattr(material, "image", None)  # SimpleMaterial (OBJ); PBRMaterial's base colour otherwise
    return image if image is not None else getattr(material, "baseColorTexture", None)


def _missing_textures(path: Path) -> list[str]:
    """Images the MTL libraries of an OBJ name (``map_Kd``) that are not there (trimesh skips them)."""
    if path.suffix.lower() != ".obj":
        return []
    missing = []
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        if line.startswith("mtllib "):
            library = path.parent / line.split(None, 1)[1].strip()
            if not library.is_file():
                missing.append(str(library))
                continue
            for entry in library.read_text(encoding="utf-8", errors="replace").splitlines():
                words = entry.split()
                if words and words[0] == "map_Kd" and len(words) > 1:
                    image = library.parent / words[-1]
                    if not image.is_file():
                        missing.append(str(image))
    return missing


def _read_image(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    if not path.is_file():
        raise AssetError(f"texture {path} does not exist")
    try:
        with Image.open(path) as image:
            return _rgb(image)
    except (UnidentifiedImageError, OSError) as exc:
        raise AssetError(f"cannot read texture {path}: {exc}") from exc


def _rgb(image: object) -> np.ndarray:
    """An image (PIL) as RGB uint8 (h, w, 3), its longer side at most :data:`MAX_TEXTURE_SIDE`."""
    from PIL import Image

    img = image.convert("RGB")  # type: ignore[attr-defined]
    side = max(img.size)
    if side > MAX_TEXTURE_SIDE:
        w, h = (max(1, round(v * MAX_TEXTURE_SIDE / side)) for v in img.size)
        img = img.resize((w, h), Image.Resampling.LANCZOS)
    return np.asarray(img, dtype=np.uint8).copy()


def _check_closed(name: str, path: Path, verts: np.ndarray, faces: np.ndarray) -> float:
    """The volume (m³) of the surface, which must be closed (every edge in exactly two faces)."""
    import trimesh

    mesh = trimesh.Trimesh(verts, faces, process=True)
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    open_edges, shared = int(np.sum(counts == 1)), int(np.sum(counts > 2))
    if open_edges or shared:
        raise AssetError(
            f"{name}: mesh {path} is not closed ({open_edges} edges in one face only, {shared} in more than "
            "two): coacd needs a watertight surface to decompose; close its holes first (e.g. Blender's "
            "3D-Print toolbox or trimesh.repair.fill_holes)")
    volume = abs(float(mesh.volume))
    if volume <= 0.0:
        raise AssetError(f"{name}: mesh {path} encloses no volume")
    return volume


def _check_plausible(name: str, size: np.ndarray, scale: float, mass: float, volume: float,
                     friction: float) -> None:
    lo, hi = EXTENT_RANGE
    extent = float(size.max())
    if not lo <= extent <= hi:
        dims = " x ".join(f"{v * 100:.3g}" for v in size)
        raise AssetError(f"{name}: at scale {scale:g} the object is {dims} cm; its largest side must be "
                         f"{lo * 100:g}-{hi * 100:g} cm (a file in mm wants --scale 0.001)")
    if not MASS_RANGE[0] <= mass <= MASS_RANGE[1]:
        raise AssetError(f"{name}: mass {mass:g} kg is out of range {MASS_RANGE[0]:g}-{MASS_RANGE[1]:g} kg")
    density = mass / volume
    if not DENSITY_RANGE[0] <= density <= DENSITY_RANGE[1]:
        raise AssetError(f"{name}: mass {mass:g} kg in {volume * 1e6:.4g} cm³ is {density:.4g} kg/m³, out of "
                         f"range {DENSITY_RANGE[0]:g}-{DENSITY_RANGE[1]:g} kg/m³ (check mass and scale)")
    if not FRICTION_RANGE[0] <= friction <= FRICTION_RANGE[1]:
        raise AssetError(f"{name}: friction {friction:g} is out of range "
                         f"{FRICTION_RANGE[0]:g}-{FRICTION_RANGE[1]:g}")


def mesh_model(name: str, path: Path, *, mass: float, friction: float = 0.8,
               rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0), scale: float = 1.0,
               texture: Path | None = None, settings: DecompositionSettings | None = None) -> ObjectModel:
    """Build an :class:`ObjectModel` called ``name`` (``category/model``) from the mesh file ``path``
    (``texture``: its image, instead of the one its material names). A textured mesh is drawn with its
    image; an untextured one in ``rgba``.

    Raises:
        AssetError: a bad name; a file :func:`read_mesh` refuses; an open mesh; a size, mass, density or
            friction out of range (see the module docstring).
    """
    check_name(name)
    if not mass > 0 or not scale > 0:
        raise AssetError(f"{name}: mass and scale must be positive, got mass={mass}, scale={scale}")
    try:
        surface = read_mesh(Path(path), texture)
    except AssetError as err:
        raise AssetError(f"{name}: {err}") from None
    verts = surface.verts * scale
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    volume = _check_closed(name, Path(path), verts, surface.faces)
    _check_plausible(name, hi - lo, scale, mass, volume, friction)
    offset = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    merged = _merged(verts + offset, surface.faces)
    hulls = convex_decomposition(*merged, settings)
    parts = tuple(Geom(f"hull_{i:03d}", "mesh", mesh=h, role="collision") for i, h in enumerate(hulls))
    visual = Geom("visual", "mesh", role="visual",
                  mesh=Mesh(verts + offset, surface.faces.astype(np.int32), surface.texcoords),
                  texture=None if surface.image is None else Texture(surface.image))
    size = hi - lo
    return ObjectModel(
        name=name, category=name.split("/")[0], seed=model_seed(name), params={"scale": scale, "mass": mass},
        size=(float(size[0]), float(size[1]), float(size[2])), mass=mass, friction=friction, rgba=rgba,
        geometry={"source": str(path), "hulls": len(hulls), "textured": surface.image is not None},
        geoms=(*with_masses(parts, mass), visual),
    )


def _merged(verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions and faces with coincident vertices merged (UV seams split them), for coacd."""
    import trimesh

    mesh = trimesh.Trimesh(verts, faces, process=True)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int32)
