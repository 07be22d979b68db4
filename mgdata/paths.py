"""Where mgdata's data lives: recipes, grasps, datasets and caches.

Recipes and grasps ship inside the package (``mgdata/recipes``, ``mgdata/grasps/data``) and are read through
:mod:`importlib.resources`. A *root* folder overrides them: ``MGDATA_ROOT`` (or ``mgdata --root DIR``) names a
folder holding ``recipes/``, ``grasps/``, ``objects/`` and ``datasets/`` (a checkout, or a user's own copy);
run from a checkout (an editable install), the checkout is the root. ``MGDATA_CACHE`` moves the cache.

Example::

    recipes_dir() / "jar.toml"     # <root>/recipes/jar.toml, else the installed package's copy
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

ROOT_ENV = "MGDATA_ROOT"


def checkout_root() -> Path | None:
    """The source checkout this package runs from (editable install), if it is one."""
    parent = Path(__file__).resolve().parent.parent
    return parent if (parent / "pyproject.toml").is_file() and (parent / "recipes").is_dir() else None


def project_root() -> Path | None:
    """The root folder overriding the packaged data: ``MGDATA_ROOT``, else the checkout, else none."""
    env = os.environ.get(ROOT_ENV)
    return Path(env) if env else checkout_root()


def _packaged(*parts: str) -> Path:
    """A folder of package data (wheels install as plain files, so it is a real path)."""
    return Path(str(files("mgdata").joinpath(*parts)))


def recipes_dir() -> Path:
    root = project_root()
    return root / "recipes" if root else _packaged("recipes")


RECIPES_GROUP = "mgdata.recipes"
"""Entry-point group: another distribution names a package whose folder holds its families' recipes."""


def recipe_dirs() -> tuple[Path, ...]:
    """Where family recipes are looked up, in order: :func:`recipes_dir`, then each installed
    distribution's ``mgdata.recipes`` entry point (a package holding ``<family>.toml`` files)."""
    from importlib.metadata import entry_points

    plugins = sorted(entry_points(group=RECIPES_GROUP), key=lambda ep: ep.name)
    return (recipes_dir(), *(Path(str(files(ep.value))) for ep in plugins))


def grasps_dir() -> Path:
    root = project_root()
    return root / "grasps" if root else _packaged("grasps", "data")


def objects_dir() -> Path | None:
    """The user's imported objects (``mgdata objects import``): ``<root>/objects``, or None without a root.
    Entries are ``objects/<category>/<model>.toml`` (docs/objects.md)."""
    root = project_root()
    return root / "objects" if root else None


def datasets_dir() -> Path:
    """Default output folder: ``<root>/datasets``, else ``./datasets`` for an installed package."""
    root = project_root()
    return (root if root else Path.cwd()) / "datasets"


def cache_dir() -> Path:
    """Derived files (decimated meshes, convex decompositions), keyed by content hash; safe to delete."""
    env = os.environ.get("MGDATA_CACHE")
    path = Path(env) if env else Path.home() / ".cache" / "mgdata"
    path.mkdir(parents=True, exist_ok=True)
    return path
