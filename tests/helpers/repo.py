"""Paths of the checkout the tests run from."""

from __future__ import annotations

import shutil
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
"""The repository root (``pyproject.toml``, ``docs/``, ``scripts/``, ``recipes/`` …)."""


def family_root(tmp: Path, family: str) -> Path:
    """A user's root folder of docs/new-family.md: the shipped recipes and grasps, plus the family that lives
    only in ``tests/families/<family>`` (its recipe, spec and skeleton)."""
    from mgdata.paths import grasps_dir, recipes_dir

    source, root = REPO / "tests" / "families" / family, tmp / "root"
    shutil.copytree(recipes_dir(), root / "recipes")
    shutil.copytree(source / "recipes", root / "recipes", dirs_exist_ok=True)
    shutil.copytree(source / "skeletons", root / "skeletons")
    (root / "grasps").symlink_to(grasps_dir())
    return root
