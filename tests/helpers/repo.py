"""Paths of the checkout the tests run from."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
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


def generate_in_root(root: Path, family: str, n: int, out: Path) -> subprocess.CompletedProcess:
    """``mgdata --root root generate --family family --n n --workers 1 --out out`` (the environment's
    ``MGDATA_ROOT`` dropped), as a user runs it."""
    env = {**{k: v for k, v in os.environ.items() if k != "MGDATA_ROOT"}, "LP_NUM_THREADS": "1"}
    mgdata = str(Path(sys.executable).with_name("mgdata"))
    return subprocess.run([mgdata, "--root", str(root), "generate", "--family", family, "--n", str(n),
                           "--workers", "1", "--out", str(out)], capture_output=True, text=True, env=env,
                          timeout=600)
