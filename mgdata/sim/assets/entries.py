"""Object entries: a user's own objects, one TOML file each under the root's ``objects/`` folder.

``objects/<category>/<model>.toml`` makes the model ``category/model`` (the asset library lists it beside the
procedural ones, so recipes, ``grasps`` and ``tasks`` see it). The mesh and its texture lie beside it::

    # objects/mug/scanned_00.toml
    category = "mug"                 # = the folder's name
    mesh = "scanned_00.obj"          # relative to this file
    texture = "scanned_00.png"       # optional only if the mesh file embeds its image (GLB)
    mass = 0.3                       # kg
    friction = 0.8                   # sliding coefficient (optional, 0.8)
    scale = 1.0                      # mesh units -> m (optional, 1.0)
    source = "mug_scan.glb"          # where it was imported from (optional, provenance only)

:func:`import_object` writes one from any mesh file (``mgdata objects import``): it checks the file as
:func:`mgdata.sim.assets.imported.mesh_model` does, rewrites the mesh as a plain OBJ (positions, UVs, faces)
and its texture as a PNG, builds the model from what it wrote, and only then moves the three files into
place, the TOML last: a refused or failed import leaves nothing behind.

Example::

    entry = import_object(Path("scan.glb"), "mug/scanned_00", objects_dir(), mass=0.3)
    get_model("mug/scanned_00").geometry["textured"]      # True
"""

from __future__ import annotations

import math
import shutil
import tempfile
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mgdata.atomic import write_text_atomic
from mgdata.errors import AssetError
from mgdata.sim.assets.imported import check_name, mesh_model, read_mesh
from mgdata.sim.assets.model import ObjectModel

KEYS = {"category": str, "mesh": str, "texture": str, "mass": float, "friction": float, "scale": float,
        "source": str}
REQUIRED = ("category", "mesh", "mass")


@dataclass(frozen=True)
class ObjectEntry:
    """One entry, read and checked (paths resolved against the entry's folder).

    Attributes:
        name: ``category/model`` (from the file's folder and stem).
        path: the TOML file.
        mesh: the mesh file.
        texture: the texture image, or None where the mesh embeds it.
        mass: kg. friction: sliding coefficient. scale: mesh units -> m.
        source: the file it was imported from (provenance), or "".
    """

    name: str
    path: Path
    mesh: Path
    texture: Path | None
    mass: float
    friction: float = 0.8
    scale: float = 1.0
    source: str = ""

    def model(self) -> ObjectModel:
        """The object model (coacd's decomposition comes from the cache after the first build)."""
        try:
            model = mesh_model(self.name, self.mesh, mass=self.mass, friction=self.friction, scale=self.scale,
                               texture=self.texture)
        except AssetError as err:
            raise AssetError(f"{self.path}: {err}") from None
        if not model.geometry["textured"]:
            raise AssetError(f"{self.path}: texture: missing, and mesh {self.mesh.name} embeds no image "
                             "(add texture = \"<image file>\")")
        return model


def read_entry(path: Path) -> ObjectEntry:
    """Read and check one entry file (keys and types; the mesh is read by :meth:`ObjectEntry.model`).

    Raises:
        AssetError: invalid TOML, an unknown or missing key, a value of the wrong type, a category that is
            not the folder's, a name that is not ``category/model``, or a mesh/texture file that is not there.
    """
    path = Path(path)
    name = f"{path.parent.name}/{path.stem}"
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise AssetError(f"{path}: not valid TOML: {err}") from None
    for key in raw:
        if key not in KEYS:
            raise AssetError(f"{path}: unknown key {key!r} (expected: {', '.join(KEYS)})")
    for key in REQUIRED:
        if key not in raw:
            raise AssetError(f"{path}: missing key {key!r}")
    values: dict[str, Any] = {}
    for key, value in raw.items():
        kind = KEYS[key]
        ok = isinstance(value, str) if kind is str else (
            isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value))
        if not ok:
            expected = "a string" if kind is str else "a number"
            raise AssetError(f"{path}: {key} = {value!r}: expected {expected}")
        values[key] = kind(value)
    if values["category"] != path.parent.name:
        raise AssetError(f"{path}: category = {values['category']!r} is not its folder's name "
                         f"{path.parent.name!r} (entries are objects/<category>/<model>.toml)")
    try:
        check_name(name)
    except AssetError as err:
        raise AssetError(f"{path}: {err}") from None
    files = {}
    for key in ("mesh", "texture"):
        if key in values:
            files[key] = path.parent / values[key]
            if not files[key].is_file():
                raise AssetError(f"{path}: {key} = {values[key]!r}: no such file {files[key]}")
    return ObjectEntry(name=name, path=path, mesh=files["mesh"], texture=files.get("texture"),
                       mass=values["mass"], friction=values.get("friction", 0.8),
                       scale=values.get("scale", 1.0), source=values.get("source", ""))


def find_entries(directory: Path) -> dict[str, ObjectEntry]:
    """Every entry under ``directory`` (``<category>/<model>.toml``), by name, sorted (none if absent)."""
    directory = Path(directory)
    if not directory.is_dir():
        return {}
    return {e.name: e for e in (read_entry(p) for p in sorted(directory.glob("*/*.toml")))}


def import_object(source: Path, name: str, directory: Path, *, mass: float, friction: float = 0.8,
                  scale: float = 1.0, texture: Path | None = None, replace: bool = False) -> ObjectEntry:
    """Turn the mesh file ``source`` into the entry ``directory/<category>/<model>.toml`` (module docstring).

    Raises:
        AssetError: the entry exists (and not ``replace``), or the file, its texture, scale, mass or
            friction is refused (:func:`mesh_model`); nothing is written then.
    """
    check_name(name)
    category, model = name.split("/")
    folder = Path(directory) / category
    target = folder / f"{model}.toml"
    if target.exists() and not replace:
        raise AssetError(f"{target} exists already (an object called {name!r}); pass --replace to overwrite")
    surface = read_mesh(Path(source), texture)
    if surface.image is None:
        raise AssetError(f"mesh {source} has no texture (no UVs, or no image): give its image with "
                         "--texture, or export it with its texture (OBJ + MTL + image, or GLB)")
    created = [d for d in (Path(directory), folder) if not d.exists()]  # removed again if the import fails
    folder.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".import-{model}-", dir=folder))
    moved: list[Path] = []
    try:
        (staging / category).mkdir()
        files = {"mesh": staging / category / f"{model}.obj", "texture": staging / category / f"{model}.png"}
        files["mesh"].write_text(_obj_text(surface.verts, surface.texcoords, surface.faces), encoding="utf-8")
        _write_png(files["texture"], surface.image)
        text = entry_text(category, f"{model}.obj", f"{model}.png", mass, friction, scale, Path(source).name)
        (staging / category / f"{model}.toml").write_text(text, encoding="utf-8")
        read_entry(staging / category / f"{model}.toml")  # the stored form is what is checked and decomposed
        mesh_model(name, files["mesh"], mass=mass, friction=friction, scale=scale, texture=files["texture"])
        for key in ("mesh", "texture"):
            moved.append(folder / files[key].name)
            files[key].replace(moved[-1])
        write_text_atomic(target, text)  # the entry exists from here on
    except BaseException:
        if not target.exists():
            for path in moved:
                path.unlink(missing_ok=True)
        shutil.rmtree(staging, ignore_errors=True)
        for d in reversed(created):
            if d.is_dir() and not any(d.iterdir()):
                d.rmdir()
        raise
    shutil.rmtree(staging, ignore_errors=True)
    return read_entry(target)


def entry_text(category: str, mesh: str, texture: str, mass: float, friction: float, scale: float,
               source: str) -> str:
    """The TOML of an entry (keys in the documented order)."""
    return (f"# mgdata object entry (docs/objects.md), written by `mgdata objects import`\n"
            f"category = {_toml_str(category)}\nmesh = {_toml_str(mesh)}\ntexture = {_toml_str(texture)}\n"
            f"mass = {float(mass)!r}\nfriction = {float(friction)!r}\nscale = {float(scale)!r}\n"
            f"source = {_toml_str(source)}\n")


def _toml_str(value: str) -> str:
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _obj_text(verts: np.ndarray, texcoords: np.ndarray | None, faces: np.ndarray) -> str:
    """A plain OBJ: ``v``, ``vt`` (one per vertex) and ``f v/vt`` lines, exact float round trip."""
    lines = ["# written by mgdata objects import: positions, texture coordinates, faces"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in verts.tolist()]
    if texcoords is not None:
        lines += [f"vt {u!r} {v!r}" for u, v in texcoords.tolist()]
        lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in faces.tolist()]
    else:
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces.tolist()]
    return "\n".join(lines) + "\n"


def _write_png(path: Path, rgb: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8), "RGB").save(path, format="PNG", optimize=False)
