"""``mgdata objects import | list``: a user's own textured meshes as mgdata objects (docs/objects.md).

``import FILE --name category/model --mass KG`` checks the file (readable, closed, textured, a plausible size
and mass), writes the entry ``<root>/objects/<category>/<model>.toml`` with the mesh as OBJ and its texture
as PNG beside it (all three or nothing), then generates and validates the model's grasps into the root's
grasp DB (``grasps/<category>.json``), as ``mgdata grasps generate`` and ``validate`` do.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mgdata.console import plain_console
from mgdata.errors import AssetError
from mgdata.grasps.commands import generate_grasps, validate_grasps
from mgdata.paths import ROOT_ENV, grasps_dir, objects_dir
from mgdata.sim.assets.imported import FRICTION_RANGE, MASS_RANGE


def _objects_root() -> Path:
    directory = objects_dir()
    if directory is None:
        raise AssetError(f"no project root to keep objects in: pass mgdata --root DIR or set {ROOT_ENV}")
    return directory


def register(app: typer.Typer) -> None:
    objects = typer.Typer(help="A user's own textured meshes as objects (objects/<category>/<model>.toml)."
                          "\n\nExample: mgdata --root myroot objects import mug.glb --name mug/scanned_00 "
                          "--mass 0.3", no_args_is_help=True)
    app.add_typer(objects, name="objects")

    @objects.command("import")
    def import_(
        file: Annotated[Path, typer.Argument(help="Mesh file: OBJ (+ MTL + image) or GLB/glTF with its "
                                             "texture; any format trimesh reads with --texture.")],
        name: Annotated[str, typer.Option("--name", help="category/model, e.g. mug/scanned_00.")],
        mass: Annotated[float, typer.Option(
            "--mass", help=f"kg ({MASS_RANGE[0]:g}-{MASS_RANGE[1]:g}).")],
        friction: Annotated[float, typer.Option(
            "--friction", help=f"Sliding friction ({FRICTION_RANGE[0]:g}-{FRICTION_RANGE[1]:g}).")] = 0.8,
        scale: Annotated[float, typer.Option(
            "--scale", help="Mesh units to metres (0.001 for a file in mm).")] = 1.0,
        texture: Annotated[Path | None, typer.Option(
            "--texture", help="Texture image, instead of the one the file names or embeds.")] = None,
        replace: Annotated[bool, typer.Option(
            "--replace", help="Overwrite an existing entry (and re-check all its grasps).")] = False,
        grasps: Annotated[bool, typer.Option(
            "--grasps/--no-grasps", help="Generate and validate its grasps after the import.")] = True,
    ) -> None:
        """Turn a textured mesh file into an object: entry, mesh, texture, collision, grasps.

        Example: mgdata --root myroot objects import scan/mug.obj --name mug/scanned_00 --mass 0.3
        """
        from mgdata.sim.assets.entries import import_object
        from mgdata.sim.assets.library import forget_user_objects, model_names

        directory = _objects_root()
        if name in model_names() and not (directory / f"{name}.toml").is_file():
            raise AssetError(f"object model {name!r} is in the asset library already; choose another name")
        entry = import_object(file, name, directory, mass=mass, friction=friction, scale=scale,
                              texture=texture, replace=replace)
        forget_user_objects()
        model = entry.model()
        dims = " x ".join(f"{v * 100:.1f}" for v in model.size)
        hulls = model.geometry["hulls"]
        typer.echo(f"wrote {entry.path} ({dims} cm, {model.mass:g} kg, {hulls} convex parts)")
        if not grasps:
            return
        root = grasps_dir()
        root.mkdir(parents=True, exist_ok=True)
        db = generate_grasps(root, [name])
        if name not in db.objects:
            typer.echo(f"{name}: no grasps: the hand cannot pick it up (it can still stand in a scene)")
            return
        validate_grasps(root, [name], all_=replace)  # a replaced object's old results may not hold

    @objects.command("list")
    def list_() -> None:
        """The root's imported objects, one line each: name, size, mass, friction, texture, source.

        Example: mgdata --root myroot objects list
        """
        from mgdata.sim.assets.library import user_objects

        directory = objects_dir()
        console = plain_console()
        for name, entry in user_objects().items():
            model = entry.model()
            dims = " x ".join(f"{v * 100:.1f}" for v in model.size)
            texture = entry.texture.name if entry.texture else "embedded"
            console.print(f"{name}  {dims} cm  {entry.mass:g} kg  friction {entry.friction:g}  "
                          f"texture {texture}  from {entry.source or '?'}")
        if not user_objects():
            console.print(f"no objects in {directory}" if directory else "no project root (--root)")
