"""Objects from mesh files: the visual is the mesh itself, the collision is its cached coacd decomposition.

Frame: the mesh is scaled, then translated so the origin is the bottom centre of its bounding box; +Z is the
file's +Z. ``geometry``: ``source`` (the file), ``hulls`` (number of convex parts). Register the result with
``mgdata.sim.assets.library.register`` so scenes can name it.

Example::

    model = mesh_model("toy/duck", Path("duck.obj"), mass=0.1)
    register(model)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mgdata.errors import AssetError
from mgdata.sim.assets.model import Geom, Mesh, ObjectModel, model_seed, with_masses
from mgdata.sim.collision import DecompositionSettings, convex_decomposition


def mesh_model(name: str, path: Path, *, mass: float, friction: float = 0.8,
               rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0), scale: float = 1.0,
               settings: DecompositionSettings | None = None) -> ObjectModel:
    """Build an :class:`ObjectModel` called ``name`` (``category/model``) from the mesh file ``path``.

    Raises:
        AssetError: a bad name, a missing or unreadable file, an empty mesh, or a non-positive mass/scale.
    """
    import trimesh

    if name.count("/") != 1 or not all(name.split("/")):
        raise AssetError(f"model name {name!r} must be 'category/model'")
    if mass <= 0 or scale <= 0:
        raise AssetError(f"{name}: mass and scale must be positive, got mass={mass}, scale={scale}")
    path = Path(path)
    if not path.is_file():
        raise AssetError(f"{name}: mesh file {path} does not exist")
    try:
        loaded = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise AssetError(f"{name}: cannot read mesh {path}: {exc}") from exc
    if len(getattr(loaded, "faces", ())) == 0:
        raise AssetError(f"{name}: mesh {path} has no faces")
    mesh = trimesh.Trimesh(np.asarray(loaded.vertices) * scale, np.asarray(loaded.faces), process=True)
    lo, hi = mesh.bounds
    mesh.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    verts, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int32)
    hulls = convex_decomposition(verts, faces, settings)
    parts = tuple(Geom(f"hull_{i:03d}", "mesh", mesh=h, role="collision") for i, h in enumerate(hulls))
    size = hi - lo
    return ObjectModel(
        name=name, category=name.split("/")[0], seed=model_seed(name), params={"scale": scale, "mass": mass},
        size=(float(size[0]), float(size[1]), float(size[2])), mass=mass, friction=friction, rgba=rgba,
        geometry={"source": str(path), "hulls": len(hulls)},
        geoms=(*with_masses(parts, mass), Geom("visual", "mesh", mesh=Mesh(verts, faces), role="visual")),
    )
