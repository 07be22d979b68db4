"""Where the project's data folders live (recipes, grasps, datasets, caches).

The package is installed editable from its checkout, so the data folders sit next to ``mgdata/``.
``MGDATA_ROOT`` points elsewhere (a copy of the checkout's data folders); ``MGDATA_CACHE`` moves the cache.
"""

from __future__ import annotations

import os
from pathlib import Path


def project_root() -> Path:
    """The folder holding ``recipes/``, ``grasps/`` and ``datasets/``."""
    env = os.environ.get("MGDATA_ROOT")
    return Path(env) if env else Path(__file__).resolve().parent.parent


def recipes_dir() -> Path:
    return project_root() / "recipes"


def grasps_dir() -> Path:
    return project_root() / "grasps"


def datasets_dir() -> Path:
    return project_root() / "datasets"


def cache_dir() -> Path:
    """Derived files (decimated meshes, convex decompositions), keyed by content hash; safe to delete."""
    env = os.environ.get("MGDATA_CACHE")
    path = Path(env) if env else Path.home() / ".cache" / "mgdata"
    path.mkdir(parents=True, exist_ok=True)
    return path
